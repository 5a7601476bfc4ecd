#include "hpr/mesh/mesh.hpp"

#include <meshoptimizer.h>

#include <Eigen/Geometry>

#include <fmt/format.h>

#include <assimp/Importer.hpp>
#include <assimp/config.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <cmath>
#include <filesystem>
#include <limits>

namespace hpr::mesh {

namespace {

Eigen::Matrix4d to_eigen(const aiMatrix4x4& m) {
  // aiMatrix4x4 holds a1..a4, b1..b4, c1..c4, d1..d4: its rows, one after the other.
  return Eigen::Map<const Eigen::Matrix<ai_real, 4, 4, Eigen::RowMajor>>(&m.a1).cast<double>();
}

void collect(const aiScene& scene, const aiNode& node, const Eigen::Matrix4d& parent, const Eigen::Vector3d& scale,
             TriangleMesh& out) {
  const Eigen::Matrix4d T = parent * to_eigen(node.mTransformation);
  for (unsigned k = 0; k < node.mNumMeshes; ++k) {
    const aiMesh& m = *scene.mMeshes[node.mMeshes[k]];
    const int base = static_cast<int>(out.vertices.size());
    for (unsigned v = 0; v < m.mNumVertices; ++v) {
      const aiVector3D& p = m.mVertices[v];
      const Eigen::Vector4d x = T * Eigen::Matrix<ai_real, 3, 1>(p.x, p.y, p.z).cast<double>().homogeneous();
      out.vertices.push_back(x.head<3>().cwiseProduct(scale));
    }
    for (unsigned f = 0; f < m.mNumFaces; ++f) {
      const aiFace& face = m.mFaces[f];
      if (face.mNumIndices != 3) continue;
      out.triangles.push_back({base + static_cast<int>(face.mIndices[0]), base + static_cast<int>(face.mIndices[1]),
                               base + static_cast<int>(face.mIndices[2])});
    }
  }
  for (unsigned c = 0; c < node.mNumChildren; ++c) collect(scene, *node.mChildren[c], T, scale, out);
}

}  // namespace

TriangleMesh load(const std::string& path, const Eigen::Vector3d& scale) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) throw MeshError(fmt::format("{}: mesh file not found", path));
  Assimp::Importer importer;
  // A COLLADA file keeps its own axes (as URDF tools read it), whatever its <up_axis> says.
  importer.SetPropertyBool(AI_CONFIG_IMPORT_COLLADA_IGNORE_UP_DIRECTION, true);
  // Identical vertices joined (an STL repeats each vertex per facet), polygons split into triangles.
  const aiScene* scene = importer.ReadFile(path, aiProcess_Triangulate | aiProcess_JoinIdenticalVertices |
                                                     aiProcess_SortByPType);
  if (scene == nullptr || scene->mRootNode == nullptr) {
    throw MeshError(fmt::format("{}: cannot read the mesh: {}", path, importer.GetErrorString()));
  }
  TriangleMesh out;
  collect(*scene, *scene->mRootNode, Eigen::Matrix4d::Identity(), scale, out);
  if (out.vertices.empty()) throw MeshError(fmt::format("{}: the mesh has no vertices", path));
  for (const auto& v : out.vertices) {
    if (!v.allFinite()) throw MeshError(fmt::format("{}: the mesh has a non-finite vertex", path));
  }
  return out;
}

TriangleMesh simplify(const TriangleMesh& mesh, std::size_t max_triangles, double max_error) {
  if (mesh.triangles.size() <= max_triangles || mesh.vertices.empty()) return mesh;
  std::vector<float> positions;
  positions.reserve(3 * mesh.vertices.size());
  Eigen::Vector3d lo = mesh.vertices.front(), hi = lo;
  for (const auto& v : mesh.vertices) {
    for (int k = 0; k < 3; ++k) positions.push_back(static_cast<float>(v(k)));
    lo = lo.cwiseMin(v);
    hi = hi.cwiseMax(v);
  }
  std::vector<unsigned> indices;
  indices.reserve(3 * mesh.triangles.size());
  for (const auto& t : mesh.triangles) {
    for (int k : t) indices.push_back(static_cast<unsigned>(k));
  }
  // Vertices at the same position welded (a file's reader keeps one per facet normal, which would
  // leave every facet a border that cannot collapse).
  std::vector<unsigned> remap(mesh.vertices.size());
  const std::size_t welded = meshopt_generateVertexRemap(remap.data(), indices.data(), indices.size(), positions.data(),
                                                         mesh.vertices.size(), 3 * sizeof(float));
  std::vector<float> welded_positions(3 * welded);
  meshopt_remapVertexBuffer(welded_positions.data(), positions.data(), mesh.vertices.size(), 3 * sizeof(float), remap.data());
  meshopt_remapIndexBuffer(indices.data(), indices.data(), indices.size(), remap.data());
  std::vector<std::size_t> original(welded);  // a vertex of `mesh` at each welded position
  for (std::size_t v = 0; v < remap.size(); ++v) original[remap[v]] = v;
  // meshoptimizer's error is relative to the mesh's extent (the radius of its bounding box).
  const double extent = std::max(0.5 * (hi - lo).norm(), 1e-9);
  std::vector<unsigned> out(indices.size());
  float achieved = 0.0F;
  const std::size_t n = meshopt_simplify(out.data(), indices.data(), indices.size(), welded_positions.data(), welded,
                                         3 * sizeof(float), 3 * max_triangles, static_cast<float>(max_error / extent), 0, &achieved);
  TriangleMesh r;
  std::vector<int> map(welded, -1);
  for (std::size_t i = 0; i + 2 < n; i += 3) {
    std::array<int, 3> t{};
    for (int k = 0; k < 3; ++k) {
      const unsigned v = out[i + static_cast<std::size_t>(k)];
      if (map[v] < 0) {
        map[v] = static_cast<int>(r.vertices.size());
        r.vertices.push_back(mesh.vertices[original[v]]);
      }
      t[static_cast<std::size_t>(k)] = map[v];
    }
    r.triangles.push_back(t);
  }
  return r;
}

std::string to_binary_stl(const TriangleMesh& mesh) {
  std::string out(80, '\0');
  const std::string header = "hpr display mesh";
  std::copy(header.begin(), header.end(), out.begin());
  auto put = [&out](const void* p, std::size_t n) { out.append(static_cast<const char*>(p), n); };
  const auto count = static_cast<std::uint32_t>(mesh.triangles.size());
  put(&count, 4);
  for (const auto& t : mesh.triangles) {
    const Eigen::Vector3d& a = mesh.vertices[static_cast<std::size_t>(t[0])];
    const Eigen::Vector3d& b = mesh.vertices[static_cast<std::size_t>(t[1])];
    const Eigen::Vector3d& c = mesh.vertices[static_cast<std::size_t>(t[2])];
    Eigen::Vector3d nrm = (b - a).cross(c - a);
    if (nrm.norm() > 0) nrm.normalize();
    for (const Eigen::Vector3d* v : std::array<const Eigen::Vector3d*, 4>{&nrm, &a, &b, &c}) {
      for (int k = 0; k < 3; ++k) {
        const auto f = static_cast<float>((*v)(k));
        put(&f, 4);
      }
    }
    const std::uint16_t attributes = 0;
    put(&attributes, 2);
  }
  return out;
}

std::vector<Eigen::Vector3d> sphere_directions(int n) {
  std::vector<Eigen::Vector3d> d;
  d.reserve(static_cast<size_t>(std::max(n, 0)));
  const double golden = M_PI * (3.0 - std::sqrt(5.0));
  for (int i = 0; i < n; ++i) {
    const double z = 1.0 - (2.0 * i + 1.0) / n;
    const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
    d.emplace_back(r * std::cos(golden * i), r * std::sin(golden * i), z);
  }
  return d;
}

std::vector<Eigen::Vector3d> hull_points(const std::vector<Eigen::Vector3d>& points, int max_points) {
  std::vector<Eigen::Vector3d> out;
  if (points.empty() || max_points <= 0) return out;
  std::vector<char> taken(points.size(), 0);
  for (const Eigen::Vector3d& dir : sphere_directions(max_points)) {
    size_t best = 0;
    double best_s = -std::numeric_limits<double>::infinity();
    for (size_t i = 0; i < points.size(); ++i) {
      const double s = dir.dot(points[i]);
      if (s > best_s) {
        best_s = s;
        best = i;
      }
    }
    if (taken[best] == 0) {
      taken[best] = 1;
      out.push_back(points[best]);
    }
  }
  return out;
}

double hull_gap(const std::vector<Eigen::Vector3d>& points, const std::vector<Eigen::Vector3d>& simplified,
                int directions) {
  auto support = [](const std::vector<Eigen::Vector3d>& p, const Eigen::Vector3d& d) {
    double s = -std::numeric_limits<double>::infinity();
    for (const auto& x : p) s = std::max(s, d.dot(x));
    return s;
  };
  double gap = 0.0;
  for (const Eigen::Vector3d& d : sphere_directions(directions)) gap = std::max(gap, support(points, d) - support(simplified, d));
  return gap;
}

}  // namespace hpr::mesh
