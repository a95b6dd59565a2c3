// Tests of dysa/core/neighbor_grid.h: the 3x3x3 run query after the counting sort finds exactly
// the neighbours a brute-force search finds, for any positions (inside, on cell borders,
// clustered, outside the domain, non-finite).
#include "dysa/core/neighbor_grid.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <random>
#include <string>
#include <vector>

namespace dysa {
namespace {

using Neighbours = std::vector<std::vector<uint32_t>>;

// Members the engineer may add for vectorised loops: sorted coordinate arrays and a trimmed
// candidate query. Checked where they exist, so this file compiles with or without them.
template <class G>
concept HasCoordinateArrays = requires(const G& g) {
  g.xs();
  g.ys();
  g.zs();
};
template <class G>
concept HasCandidateRuns = requires(const G& g) {
  g.ForEachCandidateRun(uint32_t{0}, Real{1}, [](uint32_t, uint32_t) {});
};

// The coordinate arrays, where they exist, hold the points in sorted order.
template <class G>
void ExpectCoordinateArraysMatch(const G& grid, const std::vector<Vec3>& sorted_points) {
  if constexpr (HasCoordinateArrays<G>) {
    ASSERT_EQ(grid.xs().size(), sorted_points.size());
    ASSERT_EQ(grid.ys().size(), sorted_points.size());
    ASSERT_EQ(grid.zs().size(), sorted_points.size());
    for (size_t k = 0; k < sorted_points.size(); ++k) {
      const Vec3 xyz(grid.xs()[k], grid.ys()[k], grid.zs()[k]);
      EXPECT_EQ(std::memcmp(xyz.data(), sorted_points[k].data(), sizeof(Vec3)), 0) << "k = " << k;
    }
  }
}

// Calls visit(begin, end) for the candidate runs of sorted point k where the grid has that
// query; returns false where it has not.
template <class G, class Visit>
bool ForEachCandidateRunIfAny(const G& grid, uint32_t k, Real radius, Visit&& visit) {
  if constexpr (HasCandidateRuns<G>) {
    grid.ForEachCandidateRun(k, radius, visit);
    return true;
  } else {
    return false;
  }
}

// Neighbours of every point within h (squared distance < h^2 in Real, the solver's test), as
// sorted lists of indices into `points`, by brute force. Along the axes of `period` that are
// not 0 the points repeat with that period: j is i's neighbour when any image of i, moved by a
// whole period (-L, 0 or +L, computed as the grid does: x_i + shift - x_j), is within h.
Neighbours BruteForce(const std::vector<Vec3>& points, Real h, const Vec3& period = Vec3::Zero()) {
  Neighbours out(points.size());
  const Real h2 = h * h;
  std::vector<Vec3> shifts;
  for (int sz = -1; sz <= 1; ++sz) {
    for (int sy = -1; sy <= 1; ++sy) {
      for (int sx = -1; sx <= 1; ++sx) {
        const Vec3 s(sx * period.x(), sy * period.y(), sz * period.z());
        const bool repeated = (sx == 0 || period.x() > 0) && (sy == 0 || period.y() > 0) &&
                              (sz == 0 || period.z() > 0);
        if (repeated) shifts.push_back(s);
      }
    }
  }
  for (size_t i = 0; i < points.size(); ++i) {
    for (size_t j = 0; j < points.size(); ++j) {
      for (const Vec3& s : shifts) {
        if ((points[j] - (points[i] + s)).squaredNorm() < h2) {
          out[i].push_back(uint32_t(j));
          break;
        }
      }
    }
  }
  return out;
}

// The same through the grid, by both queries. Configure, Sort, PermuteInPlace, then for each
// sorted point k the runs of ForEachNeighborRun(SortedCell(k)) (the (2 reach + 1)^3 block) and of
// ForEachCandidateRun(k, h) (the block trimmed, where the grid has that query), each mapped back to
// input indices through order(). A point visited twice would show up as a repeated index. Also
// checks the invariants of the sort.
struct GridNeighbours {
  Neighbours block;       // ForEachNeighborRun
  Neighbours candidates;  // ForEachCandidateRun, where the grid has it
  bool has_candidates;
};

GridNeighbours ThroughGrid(NeighborGrid& grid, const Aabb& domain, Real h, std::vector<Vec3> points,
                           const Periodicity& periodic = {}, int reach = 1) {
  const size_t n = points.size();
  grid.Configure(domain, h, periodic, reach);
  EXPECT_EQ(grid.reach(), reach);
  EXPECT_GE(grid.cell_size() * reach, h);
  grid.Sort(points);
  const std::vector<uint32_t> order(grid.order().begin(), grid.order().end());
  EXPECT_EQ(order.size(), n);
  {
    std::vector<uint32_t> sorted_order = order;
    std::sort(sorted_order.begin(), sorted_order.end());
    for (size_t k = 0; k < n; ++k) EXPECT_EQ(sorted_order[k], k) << "order() is no permutation";
  }
  const std::vector<Vec3> original = points;
  std::vector<Vec3> scratch;
  PermuteInPlace(grid.order(), points, scratch);
  for (size_t k = 0; k < n; ++k) {
    // PermuteInPlace: out[k] = in[order[k]], bit for bit (NaN included).
    EXPECT_EQ(std::memcmp(points[k].data(), original[order[k]].data(), sizeof(Vec3)), 0);
    // The cell of each sorted point is the one CellOf gives for its position.
    EXPECT_EQ(grid.SortedCell(uint32_t(k)), grid.CellOf(points[k])) << "k = " << k;
    const Eigen::Vector3i c = grid.SortedCell(uint32_t(k));
    for (int a = 0; a < 3; ++a) {
      EXPECT_GE(c[a], 0);
      EXPECT_LT(c[a], grid.dims()[a]);
    }
  }
  ExpectCoordinateArraysMatch(grid, points);
  GridNeighbours out{Neighbours(n), Neighbours(n), false};
  const Real h2 = h * h;
  for (size_t k = 0; k < n; ++k) {
    auto collect = [&](Neighbours& into) {
      return [&, k](uint32_t begin, uint32_t end, const Vec3& shift = Vec3::Zero()) {
        EXPECT_LT(begin, end);
        EXPECT_LE(end, n);
        for (uint32_t j = begin; j < end; ++j) {
          if ((points[j] - (points[k] + shift)).squaredNorm() < h2) {
            into[order[k]].push_back(order[j]);
          }
        }
      };
    };
    grid.ForEachNeighborRun(grid.SortedCell(uint32_t(k)), collect(out.block));
    out.has_candidates = ForEachCandidateRunIfAny(grid, uint32_t(k), h, collect(out.candidates));
  }
  for (auto& list : out.block) std::sort(list.begin(), list.end());
  for (auto& list : out.candidates) std::sort(list.begin(), list.end());
  return out;
}

std::string Describe(const std::vector<Vec3>& points, size_t i) {
  const Vec3& p = points[i];
  char text[160];
  std::snprintf(text, sizeof(text), "point %zu at (%.9g, %.9g, %.9g)", i, double(p.x()),
                double(p.y()), double(p.z()));
  return text;
}

// Lists (up to 10 per query) the points whose neighbours differ from the brute force; returns
// how many differ.
size_t CompareNeighbours(const std::vector<Vec3>& points, const Neighbours& want,
                         const Neighbours& got, const char* query) {
  size_t failures = 0;
  for (size_t i = 0; i < points.size(); ++i) {
    if (got[i] == want[i]) continue;
    if (++failures > 10) continue;
    std::string missing;
    for (uint32_t j : want[i]) {
      if (std::binary_search(got[i].begin(), got[i].end(), j)) continue;
      missing += ' ';
      missing += Describe(points, j);
    }
    ADD_FAILURE() << query << ": " << Describe(points, i) << ": found " << got[i].size()
                  << " neighbours, brute force " << want[i].size() << "; missing:" << missing;
  }
  return failures;
}

// Compares both grid queries with brute force for every point; returns the number of
// neighbour pairs, so a test can check it exercised something.
size_t ExpectSameNeighbours(const Aabb& domain, Real h, const std::vector<Vec3>& points,
                            const Periodicity& periodic = {}, int reach = 1) {
  NeighborGrid grid;
  Vec3 period = Vec3::Zero();
  for (int a = 0; a < 3; ++a) {
    if (periodic[a]) period[a] = Real(domain.max[a] - domain.min[a]);
  }
  const Neighbours want = BruteForce(points, h, period);
  const GridNeighbours got = ThroughGrid(grid, domain, h, points, periodic, reach);
  EXPECT_EQ(CompareNeighbours(points, want, got.block, "ForEachNeighborRun"), 0u);
  if (got.has_candidates) {
    EXPECT_EQ(CompareNeighbours(points, want, got.candidates, "ForEachCandidateRun"), 0u);
  }
  size_t pairs = 0;
  for (const auto& list : want) pairs += list.size();
  return pairs;
}

Aabb Box(Vec3d min, Vec3d max) { return Aabb{min, max}; }

TEST(NeighborGridTest, UniformRandomPoints) {
  std::mt19937 rng(1);
  const Aabb domain = Box(Vec3d(-2, -1, -1.5), Vec3d(2, 1.3, 1.5));
  for (Real h : {Real(0.2), Real(0.35), Real(1.0)}) {
    std::vector<Vec3> points;
    std::uniform_real_distribution<double> u(0, 1);
    for (int i = 0; i < 1500; ++i) {
      const Vec3d t(u(rng), u(rng), u(rng));
      points.push_back((domain.min + t.cwiseProduct(domain.Size())).cast<Real>());
    }
    for (int reach : {1, 2}) {
      const size_t pairs = ExpectSameNeighbours(domain, h, points, {}, reach);
      EXPECT_GT(pairs, points.size() * 2) << "h = " << h;  // more than self-pairs
    }
  }
}

TEST(NeighborGridTest, ClusteredPointsAndExactDuplicates) {
  std::mt19937 rng(2);
  std::normal_distribution<double> g(0, 1);
  const Aabb domain = Box(Vec3d(0, 0, 0), Vec3d(3, 3, 3));
  const Real h = 0.25;
  std::vector<Vec3> points;
  // Many points in one cell.
  for (int i = 0; i < 400; ++i) {
    points.push_back(
        Vec3(Real(1.1 + 0.02 * g(rng)), Real(1.1 + 0.02 * g(rng)), Real(1.1 + 0.02 * g(rng))));
  }
  // Exact duplicates, some in the cluster, some alone.
  for (int i = 0; i < 50; ++i) points.push_back(points[size_t(i) * 3]);
  for (int i = 0; i < 30; ++i) points.push_back(Vec3(2.5f, 0.3f, 1.7f));
  // A few clusters around other centres, and a thin background.
  for (int c = 0; c < 5; ++c) {
    const Vec3d centre(0.5 + 0.4 * c, 2.0 - 0.3 * c, 0.4 + 0.5 * c);
    for (int i = 0; i < 60; ++i)
      points.push_back((centre + 0.1 * Vec3d(g(rng), g(rng), g(rng))).cast<Real>());
  }
  std::uniform_real_distribution<float> u(0, 3);
  for (int i = 0; i < 200; ++i) points.push_back(Vec3(u(rng), u(rng), u(rng)));
  std::shuffle(points.begin(), points.end(), rng);
  const size_t pairs = ExpectSameNeighbours(domain, h, points);
  EXPECT_GT(pairs, 400u * 400u);
}

// Coordinates that are exact multiples of h from the domain minimum (cell borders), and values
// just below and above them, so that many pairs are almost exactly h apart across a border.
std::vector<Vec3> BorderPoints(const Aabb& domain, Real h, int cells, uint32_t seed) {
  std::vector<Real> coords[3];
  for (int a = 0; a < 3; ++a) {
    for (int k = 0; k <= cells; ++k) {
      const Real border = Real(domain.min[a]) + Real(k) * h;
      coords[a].push_back(border);
      coords[a].push_back(std::nextafter(border, -std::numeric_limits<Real>::infinity()));
      coords[a].push_back(std::nextafter(border, std::numeric_limits<Real>::infinity()));
      coords[a].push_back(border + Real(0.5) * h);
      coords[a].push_back(border + Real(0.999) * h);
      coords[a].push_back(Real(domain.min[a] + (k + 1) * double(h)));  // rounded in double
    }
  }
  std::mt19937 rng(seed);
  std::vector<Vec3> points;
  for (int i = 0; i < 2500; ++i) {
    Vec3 p;
    for (int a = 0; a < 3; ++a) p[a] = coords[a][rng() % coords[a].size()];
    points.push_back(p);
  }
  // A full lattice of border points in a corner as well.
  for (int x = 0; x < 4; ++x) {
    for (int y = 0; y < 4; ++y) {
      for (int z = 0; z < 4; ++z) {
        points.push_back(domain.min.cast<Real>() + Vec3(Real(x), Real(y), Real(z)) * h);
      }
    }
  }
  return points;
}

TEST(NeighborGridTest, PointsOnCellBordersWithExactBinaryCellSize) {
  const Aabb domain = Box(Vec3d(0, -1, 2), Vec3d(2, 1, 4));
  const Real h = 0.25;  // exactly representable: borders are exact
  EXPECT_GT(ExpectSameNeighbours(domain, h, BorderPoints(domain, h, 8, 3)), 2500u);
}

TEST(NeighborGridTest, PointsOnCellBordersWithInexactCellSize) {
  // h = 0.1 and a domain minimum that is not a binary fraction: the border coordinates and the
  // cell index computations round.
  const Aabb domain = Box(Vec3d(-0.3, -0.7, 0.13), Vec3d(1.7, 1.3, 2.13));
  for (Real h : {Real(0.1), Real(0.2), Real(0.3)}) {
    const int cells = int(std::ceil(2.0 / h));
    EXPECT_GT(ExpectSameNeighbours(domain, h, BorderPoints(domain, h, cells, 4)), 2500u)
        << "h = " << h;
  }
}

// The smallest case of the one above: two points 0.099999994 apart (< h = 0.1 in float), whose
// cell coordinates (x - min) / h round to 7.99999952 and to exactly 9.0, so CellOf puts them in
// cells 7 and 9 and neither 3x3x3 block contains the other.
TEST(NeighborGridTest, PairJustUnderHApartIsFoundDespiteRoundingOfTheCellIndex) {
  const Aabb domain = Box(Vec3d(-0.3, -0.7, 0.13), Vec3d(1.7, 1.3, 2.13));
  const Real h = 0.1f;
  const Vec3 a(0x1.fffffep-2f, 0.0f, 1.0f);  // 0.49999997
  const Vec3 b(0x1.333332p-1f, 0.0f, 1.0f);  // 0.599999964
  ASSERT_LT((b - a).squaredNorm(), h * h);
  NeighborGrid grid;
  grid.Configure(domain, h);
  EXPECT_LE(std::abs(grid.CellOf(b).x() - grid.CellOf(a).x()), 1)
      << "cells " << grid.CellOf(a).x() << " and " << grid.CellOf(b).x();
  EXPECT_EQ(ExpectSameNeighbours(domain, h, {a, b}), 4u);
}

TEST(NeighborGridTest, PointsOutsideTheDomainOnEverySide) {
  const Aabb domain = Box(Vec3d(-1, -1, -1), Vec3d(1, 1, 1));
  const Real h = 0.2;
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> near_out(-1.6, 1.6);  // up to 3 h outside each face
  std::vector<Vec3> points;
  for (int i = 0; i < 2000; ++i) {
    points.push_back(Vec3(Real(near_out(rng)), Real(near_out(rng)), Real(near_out(rng))));
  }
  // Pairs straddling each face (one inside, one outside, closer than h).
  for (int a = 0; a < 3; ++a) {
    for (Real side : {Real(-1), Real(1)}) {
      for (int i = 0; i < 20; ++i) {
        Vec3 p = Vec3(Real(near_out(rng)), Real(near_out(rng)), Real(near_out(rng))) * 0.5f;
        p[a] = side * Real(0.95);
        points.push_back(p);
        p[a] = side * Real(1.07);
        points.push_back(p);
      }
    }
  }
  // Far outside, in small groups so they have neighbours there too.
  for (double far : {-1e30, -1e6, -50.0, 50.0, 1e6, 1e30}) {
    for (int a = 0; a < 3; ++a) {
      for (int i = 0; i < 4; ++i) {
        Vec3d p(0.3, -0.2, 0.5);
        p[a] = far + (far > 1e5 || far < -1e5 ? 0.0 : 0.05 * i);
        p[(a + 1) % 3] += 0.03 * i;
        points.push_back(p.cast<Real>());
      }
    }
    points.push_back(Vec3d::Constant(far).cast<Real>());  // a far corner
    points.push_back(Vec3d::Constant(far).cast<Real>());
  }
  std::shuffle(points.begin(), points.end(), rng);
  EXPECT_GT(ExpectSameNeighbours(domain, h, points), 3 * points.size());
}

TEST(NeighborGridTest, NonFinitePointsDoNotCrashAndDoNotDisturbTheOthers) {
  const Aabb domain = Box(Vec3d(-1, -1, -1), Vec3d(1, 1, 1));
  const Real h = 0.3;
  std::mt19937 rng(6);
  std::uniform_real_distribution<float> u(-1, 1);
  std::vector<Vec3> points;
  for (int i = 0; i < 500; ++i) points.push_back(Vec3(u(rng), u(rng), u(rng)));
  const Real nan = std::numeric_limits<Real>::quiet_NaN();
  const Real inf = std::numeric_limits<Real>::infinity();
  points.insert(points.begin() + 17, Vec3(nan, nan, nan));
  points.insert(points.begin() + 100, Vec3(0.5f, nan, -0.5f));
  points.push_back(Vec3(inf, 0, 0));
  points.push_back(Vec3(-inf, 0.2f, 0));
  points.push_back(Vec3(0, 0, -inf));

  // A NaN or infinite point has no neighbour at a finite distance (NaN compares false), so the
  // brute force leaves it with an empty list; the comparison covers every point.
  NeighborGrid grid;
  const Neighbours want = BruteForce(points, h);
  const GridNeighbours got = ThroughGrid(grid, domain, h, points);
  for (size_t i = 0; i < points.size(); ++i) {
    if (!points[i].allFinite()) {
      EXPECT_TRUE(want[i].empty()) << Describe(points, i);
    }
  }
  EXPECT_EQ(CompareNeighbours(points, want, got.block, "ForEachNeighborRun"), 0u);
  if (got.has_candidates) {
    EXPECT_EQ(CompareNeighbours(points, want, got.candidates, "ForEachCandidateRun"), 0u);
  }
  // The NaN points land in cell 0 of their NaN axes.
  EXPECT_EQ(grid.CellOf(Vec3(nan, nan, nan)), Eigen::Vector3i(0, 0, 0));
}

// A stable counting sort: by cell, and in input order within a cell, so the order depends on
// the positions alone.
TEST(NeighborGridTest, SortIsStableWithinEachCell) {
  const Aabb domain = Box(Vec3d(0, 0, 0), Vec3d(1, 1, 1));
  const Real h = 0.25;
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(-0.1f, 1.1f);
  std::vector<Vec3> points;
  for (int i = 0; i < 3000; ++i) points.push_back(Vec3(u(rng), u(rng), u(rng)));
  for (int i = 0; i < 50; ++i) points.push_back(points[size_t(i) * 7]);  // exact duplicates
  NeighborGrid grid;
  grid.Configure(domain, h);
  EXPECT_EQ(grid.dims(), Eigen::Vector3i(4, 4, 4));
  grid.Sort(points);
  const auto order = grid.order();
  ASSERT_EQ(order.size(), points.size());
  for (size_t k = 1; k < order.size(); ++k) {
    const uint32_t prev_cell = grid.CellIndex(grid.SortedCell(uint32_t(k - 1)));
    const uint32_t cell = grid.CellIndex(grid.SortedCell(uint32_t(k)));
    ASSERT_LE(prev_cell, cell) << "cells out of order at k = " << k;
    if (prev_cell == cell) {
      ASSERT_LT(order[k - 1], order[k]) << "unstable within cell " << cell << " at k = " << k;
    }
  }
  // Sorting again gives the same order.
  const std::vector<uint32_t> first(order.begin(), order.end());
  grid.Sort(points);
  EXPECT_TRUE(std::equal(first.begin(), first.end(), grid.order().begin(), grid.order().end()));
}

TEST(NeighborGridTest, CellCountIsBoundedForATinyRadiusOnAHugeDomain) {
  const Aabb domain = Box(Vec3d(-1000, -1000, -1000), Vec3d(1000, 1000, 1000));
  const Real h = 0.001f;
  NeighborGrid grid;
  grid.Configure(domain, h);
  EXPECT_LE(grid.cell_count(), NeighborGrid::kMaxCells);
  EXPECT_GT(grid.cell_count(), NeighborGrid::kMaxCells / 4);  // not needlessly coarse
  EXPECT_GT(grid.cell_size(), h);
  for (int a = 0; a < 3; ++a) EXPECT_GE(grid.dims()[a] * double(grid.cell_size()), 2000.0);

  // Still exact: clusters of points a fraction of h apart, and lone points.
  std::mt19937 rng(8);
  std::uniform_real_distribution<double> u(-990, 990);
  std::uniform_real_distribution<double> tiny(-0.0008, 0.0008);
  std::vector<Vec3> points;
  for (int c = 0; c < 20; ++c) {
    const Vec3d centre(u(rng), u(rng), u(rng));
    for (int i = 0; i < 8; ++i) {
      points.push_back((centre + Vec3d(tiny(rng), tiny(rng), tiny(rng))).cast<Real>());
    }
  }
  for (int i = 0; i < 40; ++i) points.push_back(Vec3d(u(rng), u(rng), u(rng)).cast<Real>());
  EXPECT_GT(ExpectSameNeighbours(domain, h, points), points.size());
}

TEST(NeighborGridTest, ElongatedDomainStaysUnderTheCellLimit) {
  // One long axis: the cube-root estimate alone would not be enough.
  const Aabb domain = Box(Vec3d(0, 0, 0), Vec3d(1e5, 1, 1));
  NeighborGrid grid;
  grid.Configure(domain, 0.01f);
  EXPECT_LE(grid.cell_count(), NeighborGrid::kMaxCells);
  EXPECT_GE(grid.cell_size(), 0.01f);
}

TEST(NeighborGridTest, EmptyAndSinglePointSets) {
  const Aabb domain = Box(Vec3d(0, 0, 0), Vec3d(1, 1, 1));
  NeighborGrid grid;
  grid.Configure(domain, 0.1f);
  grid.Sort(std::vector<Vec3>{});
  EXPECT_TRUE(grid.order().empty());
  EXPECT_EQ(ExpectSameNeighbours(domain, 0.1f, {Vec3(0.5f, 0.5f, 0.5f)}), 1u);
}

TEST(NeighborGridTest, DomainSmallerThanOneCell) {
  const Aabb domain = Box(Vec3d(0, 0, 0), Vec3d(0.05, 0.05, 0.05));
  NeighborGrid grid;
  grid.Configure(domain, 0.2f);
  EXPECT_EQ(grid.dims(), Eigen::Vector3i(1, 1, 1));
  std::mt19937 rng(9);
  std::uniform_real_distribution<float> u(-0.5f, 0.5f);
  std::vector<Vec3> points;
  for (int i = 0; i < 200; ++i) points.push_back(Vec3(u(rng), u(rng), u(rng)));
  EXPECT_GT(ExpectSameNeighbours(domain, 0.2f, points), points.size());
}

TEST(PermuteInPlaceTest, GathersByOrder) {
  std::vector<int> data = {10, 11, 12, 13, 14};
  std::vector<int> scratch;
  const std::vector<uint32_t> order = {4, 2, 0, 1, 3};
  PermuteInPlace<int>(order, data, scratch);
  EXPECT_EQ(data, (std::vector<int>{14, 12, 10, 11, 13}));
}

// Periodic axes: neighbours across the seams (the nearest image), found once each, for points
// spread over the domain, bunched at both faces of every periodic axis, on the faces themselves
// and in the corners where two seams meet. x and y wrap, z has walls.
TEST(NeighborGridTest, PeriodicAxesFindNeighboursAcrossTheSeams) {
  const Aabb domain = Box(Vec3d(-0.2, 0.1, 0), Vec3d(0.8, 0.73, 0.35));
  const Periodicity periodic = {true, true, false};
  for (Real h : {Real(0.1), Real(0.13), Real(0.2)}) {
    std::mt19937 rng(11);
    std::uniform_real_distribution<double> ux(-0.2, 0.8), uy(0.1, 0.73), uz(0, 0.35);
    std::uniform_real_distribution<double> edge(0, 1.5 * h);
    std::vector<Vec3> points;
    for (int i = 0; i < 1500; ++i) points.push_back(Vec3d(ux(rng), uy(rng), uz(rng)).cast<Real>());
    for (int i = 0; i < 300; ++i) {
      Vec3d p(ux(rng), uy(rng), uz(rng));
      const int a = i % 2;  // x or y
      p[a] = (i / 2) % 2 ? domain.min[a] + edge(rng) : domain.max[a] - edge(rng);
      if (i % 5 == 0) p[1 - a] = (i / 5) % 2 ? domain.min[1 - a] : domain.max[1 - a];
      points.push_back(p.cast<Real>());
    }
    points.push_back(domain.min.cast<Real>());
    points.push_back(Vec3d(domain.max.x(), domain.max.y(), 0.1).cast<Real>());
    for (int reach : {1, 2}) {
      NeighborGrid grid;
      grid.Configure(domain, h, periodic, reach);
      for (int a = 0; a < 2; ++a) {
        // The period is tiled by whole cells of at least h / reach.
        EXPECT_GE(grid.cell_sizes()[a] * reach, h);
        EXPECT_NEAR(grid.dims()[a] * grid.cell_sizes()[a], domain.Size()[a], 1e-12);
      }
      const size_t pairs = ExpectSameNeighbours(domain, h, points, periodic, reach);
      // Compared with the same points without wrapping: the seams add neighbours.
      const size_t unwrapped = ExpectSameNeighbours(domain, h, points, {}, reach);
      EXPECT_GT(pairs, unwrapped + 100) << "h = " << h << ", reach " << reach;
    }
  }
}

// The shortest period the grid takes, 3 cells: each cell of the 3x3x3 block is then a different
// one, so no neighbour is visited twice (a repeated index would fail the comparison).
TEST(NeighborGridTest, PeriodOfThreeCells) {
  const Aabb domain = Box(Vec3d(0, 0, 0), Vec3d(1, 1, 0.31));
  std::mt19937 rng(12);
  std::uniform_real_distribution<double> u(0, 1), uz(0, 0.31);
  std::vector<Vec3> points;
  for (int i = 0; i < 1200; ++i) points.push_back(Vec3d(u(rng), u(rng), uz(rng)).cast<Real>());
  NeighborGrid grid;
  grid.Configure(domain, 0.1f, {false, false, true});
  EXPECT_EQ(grid.dims().z(), 3);
  EXPECT_GT(ExpectSameNeighbours(domain, 0.1f, points, {false, false, true}), points.size());
  EXPECT_THROW(grid.Configure(domain, 0.11f, {false, false, true}), std::invalid_argument);
}

// The same with half-support cells: a period of 5 cells, each of the 5x5x5 block's a different
// one; under 5 (2.5 supports) the grid refuses it, as it refuses a reach it does not have.
TEST(NeighborGridTest, PeriodOfFiveHalfCells) {
  const Aabb domain = Box(Vec3d(0, 0, 0), Vec3d(1, 1, 0.26));
  std::mt19937 rng(13);
  std::uniform_real_distribution<double> u(0, 1), uz(0, 0.26);
  std::vector<Vec3> points;
  for (int i = 0; i < 1200; ++i) points.push_back(Vec3d(u(rng), u(rng), uz(rng)).cast<Real>());
  NeighborGrid grid;
  grid.Configure(domain, 0.1f, {false, false, true}, 2);
  EXPECT_EQ(grid.dims().z(), 5);
  EXPECT_GT(ExpectSameNeighbours(domain, 0.1f, points, {false, false, true}, 2), points.size());
  EXPECT_THROW(grid.Configure(domain, 0.11f, {false, false, true}, 2), std::invalid_argument);
  EXPECT_THROW(grid.Configure(domain, 0.1f, {}, 0), std::invalid_argument);
  EXPECT_THROW(grid.Configure(domain, 0.1f, {}, NeighborGrid::kMaxReach + 1),
               std::invalid_argument);
}

// Why a reach of 2: on a fluid lattice (spacing d, support 2 d) half-support cells hand a
// particle far fewer candidates for the same neighbours: (5/2)^3 = 15.6 support-cubes against
// 27 in the bulk.
TEST(NeighborGridTest, HalfSupportCellsTestFewerCandidates) {
  const Real d = 0.01f, support = 2 * d;
  const Aabb domain = Box(Vec3d(0, 0, 0), Vec3d(0.3, 0.3, 0.3));
  std::vector<Vec3> points;
  for (int z = 0; z < 30; ++z)
    for (int y = 0; y < 30; ++y)
      for (int x = 0; x < 30; ++x)
        points.push_back(Vec3(d * (x + 0.5f), d * (y + 0.5f), d * (z + 0.5f)));
  uint64_t candidates[3] = {};
  for (int reach : {1, 2}) {
    NeighborGrid grid;
    grid.Configure(domain, support, {}, reach);
    grid.Sort(points);
    for (uint32_t k = 0; k < points.size(); ++k) {
      grid.ForEachNeighborRun(grid.SortedCell(k), [&](uint32_t begin, uint32_t end, const Vec3&) {
        candidates[reach] += end - begin;
      });
    }
  }
  const double ratio = double(candidates[2]) / double(candidates[1]);
  EXPECT_LT(ratio, 0.7) << candidates[2] << " against " << candidates[1];
  EXPECT_GT(ratio, 0.4) << candidates[2] << " against " << candidates[1];
}

}  // namespace
}  // namespace dysa
