#pragma once
/// \file
/// Mesh files (STL, COLLADA, OBJ and whatever else Assimp reads) as vertex sets, and the bounded
/// convex hull a simulator collides with.

#include <Eigen/Core>
#include <array>
#include <stdexcept>
#include <string>
#include <vector>

namespace hpr::mesh {

/// A mesh file that cannot be read: the message names the file and what the reader said.
class MeshError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct TriangleMesh {
  std::vector<Eigen::Vector3d> vertices;         ///< in the mesh file's frame, scaled [m]
  std::vector<std::array<int, 3>> triangles;     ///< vertex indices
};

/// Reads every mesh of a file into one vertex and triangle list, each vertex multiplied
/// component-wise by `scale` (the URDF's <mesh scale>), with the file's node transforms applied.
/// COLLADA files are read in their own units and up axis, as the URDF convention expects.
TriangleMesh load(const std::string& path, const Eigen::Vector3d& scale = Eigen::Vector3d::Ones());

/// At most `max_points` points of the convex hull of `points`: the support point (farthest along the
/// direction) for `max_points` directions spread evenly over the sphere, duplicates removed. Their
/// hull lies inside the exact hull and touches it in every sampled direction; `hull_gap` measures
/// how far inside.
std::vector<Eigen::Vector3d> hull_points(const std::vector<Eigen::Vector3d>& points, int max_points);

/// The largest difference, over `directions` directions spread evenly over the sphere, between the
/// support distances of `points` and of `simplified` [m]: how far the simplified hull lies inside
/// the exact one at worst (0 when nothing was lost).
double hull_gap(const std::vector<Eigen::Vector3d>& points, const std::vector<Eigen::Vector3d>& simplified,
                int directions = 2000);

/// A lighter mesh for display: edge collapses (meshoptimizer's quadric simplifier) down to at most
/// `max_triangles`, stopping earlier where the next collapse would move the surface by more than
/// `max_error` [m]. Vertices the simplified mesh keeps are vertices of `mesh`; unused ones are dropped.
TriangleMesh simplify(const TriangleMesh& mesh, std::size_t max_triangles, double max_error);

/// The mesh as a binary STL file (80-byte header, facet normals from the vertex order).
std::string to_binary_stl(const TriangleMesh& mesh);

/// `n` unit vectors spread evenly over the sphere (a Fibonacci lattice).
std::vector<Eigen::Vector3d> sphere_directions(int n);

}  // namespace hpr::mesh
