// Smoothing kernels of the seed model, normalised in 3D (integral over the ball of radius h = 1).
//
// r is the distance between two particles and h the smoothing radius; every kernel is zero for
// r >= h. Density uses spiky^2 and near density spiky^3 (Clavet et al. 2005, "Particle-based
// viscoelastic fluid simulation", in the form of Sebastian Lague's fluid simulation); viscosity
// uses poly6 (Mueller et al. 2003, "Particle-based fluid simulation for interactive
// applications"). Normalisation constants: int_0^h 4 pi r^2 (h - r)^2 dr = 2 pi h^5 / 15,
// int_0^h 4 pi r^2 (h - r)^3 dr = pi h^6 / 15, int_0^h 4 pi r^2 (h^2 - r^2)^3 dr = 64 pi h^9 / 315.
#pragma once

#include <cmath>
#include <numbers>

namespace dysa {

template <class T>
struct Spiky2 {
  static T W(T r, T h) {
    if (r >= h) return 0;
    const T v = h - r;
    return T(15) / (T(2) * std::numbers::pi_v<T> * Pow5(h)) * v * v;
  }
  // dW/dr
  static T dW(T r, T h) {
    if (r >= h) return 0;
    return -T(15) / (std::numbers::pi_v<T> * Pow5(h)) * (h - r);
  }
  static T Pow5(T h) { return h * h * h * h * h; }
};

template <class T>
struct Spiky3 {
  static T W(T r, T h) {
    if (r >= h) return 0;
    const T v = h - r;
    return T(15) / (std::numbers::pi_v<T> * Pow6(h)) * v * v * v;
  }
  static T dW(T r, T h) {
    if (r >= h) return 0;
    const T v = h - r;
    return -T(45) / (std::numbers::pi_v<T> * Pow6(h)) * v * v;
  }
  static T Pow6(T h) { return h * h * h * h * h * h; }
};

template <class T>
struct Poly6 {
  static T W(T r, T h) {
    if (r >= h) return 0;
    const T v = h * h - r * r;
    return T(315) / (T(64) * std::numbers::pi_v<T> * Pow9(h)) * v * v * v;
  }
  static T dW(T r, T h) {
    if (r >= h) return 0;
    const T v = h * h - r * r;
    return -T(6) * T(315) / (T(64) * std::numbers::pi_v<T> * Pow9(h)) * r * v * v;
  }
  static T Pow9(T h) {
    const T h3 = h * h * h;
    return h3 * h3 * h3;
  }
};

// The constant factors of the kernels above for one h, hoisted out of the neighbour loops:
// W_spiky2 = spiky2 * (h - r)^2, dW_spiky2/dr = -spiky2_grad * (h - r), and so on.
template <class T>
struct SeedKernelFactors {
  explicit SeedKernelFactors(T h_in)
      : h(h_in),
        h2(h_in * h_in),
        spiky2(Spiky2<T>::W(0, h_in) / (h_in * h_in)),
        spiky2_grad(-Spiky2<T>::dW(0, h_in) / h_in),
        spiky3(Spiky3<T>::W(0, h_in) / (h_in * h_in * h_in)),
        spiky3_grad(-Spiky3<T>::dW(0, h_in) / (h_in * h_in)),
        poly6(Poly6<T>::W(0, h_in) / (h_in * h_in * h_in * h_in * h_in * h_in)) {}
  T h, h2, spiky2, spiky2_grad, spiky3, spiky3_grad, poly6;
};

// The cubic spline kernel of the physical solvers (Monaghan 1992, "Smoothed particle
// hydrodynamics", ARA&A 30), written with its support radius H = 2 h (h the smoothing length)
// and q = r / H, as in Becker & Teschner 2007 and SPlisHSPlasH:
//   W(q) = 8 / (pi H^3) * { 6 (q^3 - q^2) + 1   for q <= 1/2
//                         { 2 (1 - q)^3          for 1/2 < q <= 1,   0 beyond.
// dW/dr = 48 / (pi H^4) * { q (3 q - 2) ; -(1 - q)^2 }. The physical solvers take H = 2 d with
// d the particle spacing (h = d), about 33 neighbours in a lattice.
template <class T>
struct CubicSpline {
  static T Sigma(T support) { return T(8) / (std::numbers::pi_v<T> * support * support * support); }
  static T W(T r, T support) {
    const T q = r / support;
    if (q > 1) return 0;
    if (q <= T(0.5)) return Sigma(support) * (T(6) * (q * q * q - q * q) + 1);
    const T v = 1 - q;
    return Sigma(support) * T(2) * v * v * v;
  }
  // dW/dr (<= 0)
  static T dW(T r, T support) {
    const T q = r / support;
    if (q > 1) return 0;
    const T scale = T(6) * Sigma(support) / support;
    if (q <= T(0.5)) return scale * q * (T(3) * q - T(2));
    const T v = 1 - q;
    return -scale * v * v;
  }
};

// The Wendland C2 kernel (Wendland 1995, "Piecewise polynomial, positive definite and compactly
// supported radial functions of minimal degree", Adv. Comput. Math. 4), as DualSPHysics uses it
// (Dehnen & Aly 2012 for its stability at large supports), written like CubicSpline with its
// support H = 2 h and q = r / H:
//   W(q) = 21 / (2 pi H^3) (1 - q)^4 (1 + 4 q)  for q <= 1, 0 beyond
// (the usual 21 / (16 pi h^3) (1 - r/2h)^4 (1 + 2 r/h) with h = H / 2);
// dW/dr = -21 / (2 pi H^4) 20 q (1 - q)^3. Unlike the cubic spline it has no pairing
// instability however many neighbours the support holds, so a larger h / d buys a smoother
// pressure without particles clumping.
template <class T>
struct WendlandC2 {
  static T Sigma(T support) {
    return T(21) / (T(2) * std::numbers::pi_v<T> * support * support * support);
  }
  static T W(T r, T support) {
    const T q = r / support;
    if (q > 1) return 0;
    const T v = 1 - q;
    const T v2 = v * v;
    return Sigma(support) * (v2 * v2) * (T(4) * q + 1);
  }
  // dW/dr (<= 0)
  static T dW(T r, T support) {
    const T q = r / support;
    if (q > 1) return 0;
    const T v = 1 - q;
    return -(T(20) * Sigma(support) / support) * q * (v * v * v);
  }
};

// The physical solvers' kernel: a scene parameter (Params::kernel), chosen at run time. The
// branch is the same for every pair of a step, so it costs a predicted jump, not a divergence.
enum class KernelKind : int { kCubicSpline = 0, kWendlandC2 = 1 };

template <class T>
struct PhysicalKernel {
  KernelKind kind = KernelKind::kCubicSpline;
  T support = 0;  // m, H = 2 h

  T W(T r) const {
    return kind == KernelKind::kWendlandC2 ? WendlandC2<T>::W(r, support)
                                           : CubicSpline<T>::W(r, support);
  }
  T dW(T r) const {
    return kind == KernelKind::kWendlandC2 ? WendlandC2<T>::dW(r, support)
                                           : CubicSpline<T>::dW(r, support);
  }
  template <class U>
  PhysicalKernel<U> Cast() const {
    return {kind, U(support)};
  }
};

// The gradient moment of `kernel` on a cubic lattice of spacing d (volume d^3 per particle):
// for a linear field f, the SPH gradient sum_j d^3 (f_j - f_i) grad W_ij equals mu grad f with
// mu = -(1/3) sum_{j != i} d^3 r_ij W'(r_ij) (the lattice's symmetry makes the moment tensor
// mu I). mu is 1 for an exact gradient; the cubic spline at support 2 d gives 1.0200: the
// pressure gradient comes out 2% too strong, so a fluid at rest settles with a pressure 2% below
// rho g (H - y). The physical solvers divide their pressure gradients by it. Larger supports
// (h / d) and the Wendland kernel bring it nearer 1 (kernels_test).
inline double LatticeGradientMoment(const PhysicalKernel<double>& kernel, double spacing) {
  const int reach = int(kernel.support / spacing) + 1;
  double sum = 0;
  for (int i = -reach; i <= reach; ++i) {
    for (int j = -reach; j <= reach; ++j) {
      for (int k = -reach; k <= reach; ++k) {
        const double r = spacing * std::sqrt(double(i * i + j * j + k * k));
        if (r > 0) sum += r * kernel.dW(r);
      }
    }
  }
  return -sum * spacing * spacing * spacing / 3;
}

// The kernel sum of `kernel` on a cubic lattice of spacing d, the particle's own term included:
// d^3 sum_j W(r_ij), the summation density of the rest lattice over rho0. It is not 1: 0.99997
// for the cubic spline at support 2 d, 1.0018 for Wendland C2 at 3.46 d (1.034 at 2 d), which
// would start a lattice at rest 0.18% compressed (Tait: 1.6 kPa at c0 = 50 m/s) everywhere but
// at its free surface. Where it exceeds 1 (Model::density_moment) the physical solvers divide
// their summation densities by it and scale the boundary volumes by it, so that the rest lattice
// has rho0 at every wall as inside.
inline double LatticeDensityMoment(const PhysicalKernel<double>& kernel, double spacing) {
  const int reach = int(kernel.support / spacing) + 1;
  double sum = 0;
  for (int i = -reach; i <= reach; ++i) {
    for (int j = -reach; j <= reach; ++j) {
      for (int k = -reach; k <= reach; ++k) {
        sum += kernel.W(spacing * std::sqrt(double(i * i + j * j + k * k)));
      }
    }
  }
  return sum * spacing * spacing * spacing;
}

// The viscosity moment of `kernel` on the same lattice: for a shear flow, the laminar
// viscosity term of the physical solvers (Monaghan 2005, becker_teschner_solver.h),
// 2 (dim + 2) nu sum_j d^3 (v_ij . x_ij) / (r_ij^2 + eps) grad W_ij, equals lambda nu laplacian(v)
// with lambda = (dim + 2) sum_{j != i} d^3 x^2 y^2 (-W'(r)) / (r (r^2 + eps)) (the Taylor
// expansion's fourth moment; x, y the components of x_ij across and along the flow). The
// continuum integral makes lambda 1 (without eps); the cubic spline's lattice at support 2 d
// gives 0.708: the fluid's viscosity came out 29% low (Poiseuille flow settled 41% too fast,
// tests/validation). The physical solvers divide their viscous terms by it. eps = 0.01 h^2 with
// h = support / 2, as in the viscosity term.
inline double LatticeViscosityMoment(const PhysicalKernel<double>& kernel, double spacing) {
  const int reach = int(kernel.support / spacing) + 1;
  const double h = 0.5 * kernel.support;
  const double eps = 0.01 * h * h;
  double sum = 0;
  for (int i = -reach; i <= reach; ++i) {
    for (int j = -reach; j <= reach; ++j) {
      for (int k = -reach; k <= reach; ++k) {
        const double x = spacing * i, y = spacing * j;
        const double r = spacing * std::sqrt(double(i * i + j * j + k * k));
        if (r > 0) sum -= x * x * y * y * kernel.dW(r) / (r * (r * r + eps));
      }
    }
  }
  return 5 * sum * spacing * spacing * spacing;
}

}  // namespace dysa
