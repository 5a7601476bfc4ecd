// Display meshes: the simplifier keeps its error bound on a surface known in closed form (a sphere),
// and the binary STL writer round-trips through Assimp's reader.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "hpr/mesh/mesh.hpp"
#include "process_group.hpp"

namespace {

using hpr::mesh::TriangleMesh;

/// A UV sphere of radius r with n_lon × n_lat quads (two triangles each, poles as fans).
TriangleMesh uv_sphere(double r, int n_lon, int n_lat) {
  TriangleMesh m;
  m.vertices.emplace_back(0, 0, r);
  for (int i = 1; i < n_lat; ++i) {
    const double th = M_PI * i / n_lat;
    for (int j = 0; j < n_lon; ++j) {
      const double ph = 2 * M_PI * j / n_lon;
      m.vertices.emplace_back(r * std::sin(th) * std::cos(ph), r * std::sin(th) * std::sin(ph), r * std::cos(th));
    }
  }
  m.vertices.emplace_back(0, 0, -r);
  const int south = static_cast<int>(m.vertices.size()) - 1;
  auto at = [n_lon](int ring, int j) { return 1 + ring * n_lon + (j % n_lon); };
  for (int j = 0; j < n_lon; ++j) m.triangles.push_back({0, at(0, j), at(0, j + 1)});
  for (int i = 0; i + 1 < n_lat - 1; ++i) {
    for (int j = 0; j < n_lon; ++j) {
      m.triangles.push_back({at(i, j), at(i + 1, j), at(i + 1, j + 1)});
      m.triangles.push_back({at(i, j), at(i + 1, j + 1), at(i, j + 1)});
    }
  }
  for (int j = 0; j < n_lon; ++j) m.triangles.push_back({south, at(n_lat - 2, j + 1), at(n_lat - 2, j)});
  return m;
}

/// The largest distance inside the sphere of a point of the mesh's surface (sampled per triangle).
double deepest_below_sphere(const TriangleMesh& m, double r) {
  double worst = 0;
  for (const auto& t : m.triangles) {
    const auto& a = m.vertices[static_cast<std::size_t>(t[0])];
    const auto& b = m.vertices[static_cast<std::size_t>(t[1])];
    const auto& c = m.vertices[static_cast<std::size_t>(t[2])];
    for (double u = 0; u <= 1.0; u += 0.25) {
      for (double v = 0; u + v <= 1.0; v += 0.25) worst = std::max(worst, r - (a + u * (b - a) + v * (c - a)).norm());
    }
  }
  return worst;
}

TEST(DisplayMesh, SimplifiedSphereStaysWithinTheErrorBound) {
  const double r = 0.1;
  const TriangleMesh fine = uv_sphere(r, 200, 100);
  ASSERT_GT(fine.triangles.size(), 39000U);
  EXPECT_LT(deepest_below_sphere(fine, r), 1e-4) << "the fine sphere itself is close to the sphere";
  for (double bound : {0.001, 0.004}) {
    const TriangleMesh s = hpr::mesh::simplify(fine, 2000, bound);
    EXPECT_LE(s.triangles.size(), 2000U) << bound;
    EXPECT_GT(s.triangles.size(), 100U) << bound;
    EXPECT_LT(deepest_below_sphere(s, r), bound) << "error bound " << bound << ", " << s.triangles.size() << " triangles";
    for (const auto& v : s.vertices) EXPECT_NEAR(v.norm(), r, 1e-12) << "kept vertices are the mesh's own";
  }
  // A bound tighter than 2000 triangles allow stops the simplification first. (meshoptimizer's error
  // is a quadric estimate, not a strict distance: at this scale, a tenth of the fine mesh's own
  // facet size, it is exceeded by a few tenths of a millimetre, so only the count is checked.)
  const TriangleMesh tight = hpr::mesh::simplify(fine, 2000, 1e-5);
  EXPECT_GT(tight.triangles.size(), 2000U);
  EXPECT_LT(deepest_below_sphere(tight, r), 1e-3);
  // A mesh already small enough is returned as it is.
  EXPECT_EQ(hpr::mesh::simplify(fine, 50000, 0.001).triangles.size(), fine.triangles.size());
}

TEST(DisplayMesh, BinaryStlRoundTripsThroughAssimp) {
  const TriangleMesh m = hpr::mesh::simplify(uv_sphere(0.05, 40, 20), 300, 0.01);
  const std::string path = hpr::test::temp_dir("display_mesh") + "/sphere.stl";
  {
    std::ofstream f(path, std::ios::binary);
    const std::string bytes = hpr::mesh::to_binary_stl(m);
    EXPECT_EQ(bytes.size(), 84U + 50U * m.triangles.size());
    f << bytes;
  }
  const TriangleMesh back = hpr::mesh::load(path);
  ASSERT_EQ(back.triangles.size(), m.triangles.size());
  for (std::size_t i = 0; i < m.triangles.size(); ++i) {
    for (int k = 0; k < 3; ++k) {
      const auto& a = m.vertices[static_cast<std::size_t>(m.triangles[i][static_cast<std::size_t>(k)])];
      const auto& b = back.vertices[static_cast<std::size_t>(back.triangles[i][static_cast<std::size_t>(k)])];
      EXPECT_LT((a - b).norm(), 1e-7) << "triangle " << i << " (single precision in the file)";
    }
  }
}

}  // namespace
