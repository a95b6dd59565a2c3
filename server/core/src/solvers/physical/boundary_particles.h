// Static walls and obstacles as boundary particles (Akinci, Ihmsen, Akinci, Solenthaler,
// Teschner 2012, "Versatile rigid-fluid coupling for incompressible SPH", ACM TOG 31(4)),
// shared by the physical solvers.
//
// The domain walls and every obstacle surface are sampled with particles about one particle
// spacing d apart, in layers behind the surface (LayersFor outside the domain; obstacles are
// filled), each layer d/2 + k d from the surface: where the surface is a lattice plane of the
// fluid, the boundary continues the fluid's lattice. Each boundary particle b gets the volume of
// eq. (4) of the paper, V_b = 1 / sum_k W(x_b - x_k) (b included; the sum is completed by the
// fluid's rest lattice on the other side, see the constructor), so that a denser or sparser
// sampling weighs the same; its "mass" towards fluid of rest density rho0 is Psi_b = rho0 V_b
// (eq. 5). A fluid particle then adds
// sum_b Psi_b W(x_i - x_b) to its density and feels the pressure of the boundary.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "dysa/core/model.h"
#include "dysa/core/neighbor_grid.h"

namespace dysa {

class BoundaryParticles {
 public:
  // The layers behind a flat wall that cover the kernel's support: a fluid particle at the wall
  // then has a full neighbourhood, fluid on one side and boundary on the other. Two for the
  // support 2 d, four for 3.46 d (Wendland C2 at h = 1.732 d).
  static int LayersFor(double support, double spacing);
  // Obstacles are sampled through: as many layers as reach their centre.
  static constexpr int kSolid = 1 << 20;

  // Samples the domain walls and the obstacles of `model` at spacing `spacing`, sorts the
  // samples on a grid laid like the fluid's (NeighborGrid::Configure(model.domain, support,
  // model.periodic)),
  // so a fluid particle's cell indexes both, and computes the volumes with the kernel
  // model.kernel_kind of support `support`.
  BoundaryParticles(const Model& model, double spacing, double support);

  size_t size() const { return volume_.size(); }
  // Positions (grid.xs/ys/zs, padded) in the grid's order, and the volumes in the same order
  // (m^3, also padded with zeros).
  const NeighborGrid& grid() const { return grid_; }
  std::span<const Real> volume() const { return {volume_.data(), volume_.size()}; }
  const Real* padded_volume() const { return padded_volume_.data(); }
  // Whether each boundary particle (grid order) is a sample of a no-slip wall (Model::no_slip).
  std::span<const uint8_t> no_slip() const { return {no_slip_.data(), no_slip_.size()}; }
  bool HasNoSlip() const {
    return std::find(no_slip_.begin(), no_slip_.end(), 1) != no_slip_.end();
  }

  // Moving obstacles (ObstacleMotion). Obstacles are numbered boxes first, then spheres, as in
  // the Model. Whether any obstacle of the model moves: only then does the sampling keep what
  // MoveObstacles needs, so a static scene pays nothing.
  bool HasMovingObstacles() const { return !rest_position_.empty(); }
  // Places every obstacle's samples at its rest (scene) position plus displacement[o] and gives
  // them velocity[o] (one per obstacle, the model's count), then sorts all samples on the grid
  // again, carrying their volumes and no-slip flags. The volumes stay those computed at the
  // scene's positions (recomputing them is a neighbour sweep of every sample per step): a
  // sample's volume depends only on the samples and the fluid-side lattice within its support,
  // which move with it inside one rigid obstacle, so this is exact for an obstacle that starts
  // and stays more than a support (2 d) away from every other solid. Its limit: solids within a
  // support of each other at the scene's positions lower each other's volumes (each counts the
  // other where it expects fluid), and keep the lowered volumes once moved apart. A gate
  // standing on the floor: after the lift, the floor's samples under where it stood and the
  // gate's lowest samples weigh up to a third less, over a strip the gate's thickness wide
  // (one support deep); the wall contact, which reads the geometry, still holds the fluid out.
  void MoveObstacles(std::span<const Vec3d> displacement, std::span<const Vec3> velocity);
  // m/s, per sample in grid order: its obstacle's velocity (0 for the walls). Empty unless
  // HasMovingObstacles().
  std::span<const Vec3> velocity() const { return {velocity_.data(), velocity_.size()}; }
  // MoveObstacles's inputs, per sample in sampling order (the GPU's move_boundary places from
  // them): the rest position, the obstacle (-1: a domain wall), the volume and the no-slip
  // flag. Empty unless HasMovingObstacles().
  std::span<const Vec3> rest_position() const { return rest_position_; }
  std::span<const int32_t> obstacle() const { return obstacle_; }
  std::span<const Real> rest_volume() const { return rest_volume_; }
  std::span<const uint8_t> rest_no_slip() const { return rest_no_slip_; }

 private:
  NeighborGrid grid_;
  std::vector<Real> volume_;
  std::vector<Real> padded_volume_;
  std::vector<uint8_t> no_slip_;
  // With moving obstacles, per sample in sampling order: the position at the scene's geometry,
  // the obstacle (-1: a domain wall), the volume and the no-slip flag; and the velocity in grid
  // order.
  std::vector<Vec3> rest_position_;
  std::vector<int32_t> obstacle_;
  std::vector<Real> rest_volume_;
  std::vector<uint8_t> rest_no_slip_;
  std::vector<Vec3> position_scratch_;
  std::vector<Vec3> velocity_;
};

// The samplers, appending to `out` the boundary particles and, when `fluid_side` is given, to it
// the fluid's lattice continued `layers` deep (at most `fluid_side_layers` for obstacles, which
// are sampled deeper than the support reaches) on the other side of the surface (for the
// volumes; see the constructor). Lattices adjust their step per axis (the extent over
// round(extent / spacing)) so that both ends of every edge are sampled alike.
// Walls: the lattice over the domain grown by `layers` spacings across its non-periodic axes,
// less the points inside it (a periodic axis has no walls).
void SampleDomainWalls(const Aabb& domain, const Periodicity& periodic, double spacing, int layers,
                       std::vector<Vec3>& out, std::vector<Vec3>* fluid_side = nullptr);
// Box obstacle: the lattice of the box, less the points deeper than `layers` spacings.
void SampleBox(const Aabb& box, double spacing, int layers, std::vector<Vec3>& out,
               std::vector<Vec3>* fluid_side = nullptr, int fluid_side_layers = 2);
// Sphere obstacle: concentric shells of radius R - (k + 1/2) d, each a Fibonacci spiral of
// about 4 pi r^2 / d^2 points (evenly spread, no poles); a sphere smaller than one spacing is
// its centre. Its fluid side: shells of radius R + (k + 1/2) d.
void SampleSphere(const SphereObstacle& sphere, double spacing, int layers, std::vector<Vec3>& out,
                  std::vector<Vec3>* fluid_side = nullptr, int fluid_side_layers = 2);

}  // namespace dysa
