#pragma once
/// \file
/// What the browser needs to draw a robot: a URDF for display written from the loaded description
/// (every mesh renamed to a URL the viewer serves; links without visual geometry drawn with their
/// collision geometry, links without either as their inertia's equivalent box; `<mimic>` kept so followers move with their leaders), the mesh files behind
/// the URLs, and a JSON summary (base link, feet and soles, held and locked joints).

#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "hpr/model/robot.hpp"

namespace hpr::viewer {

struct DisplayOptions {
  /// STL and OBJ meshes are simplified to at most this many triangles each (0: served as they are),
  std::size_t mesh_max_triangles = 1500;
  /// unless that would move their surface by more than this [m]. COLLADA files (which carry their
  /// own materials and transforms) are served as they are.
  double mesh_max_error = 0.002;
};

struct DisplayRobot {
  std::string urdf;                     ///< URDF text for urdf-loader
  std::vector<std::string> mesh_files;  ///< file behind /robot/mesh/<i>.<ext>
  std::vector<std::string> mesh_urls;   ///< "/robot/mesh/<i>.<ext>"
  std::vector<std::string> mesh_data;   ///< what is served at each URL (a simplified binary STL, or the file)
  std::size_t triangles_in = 0, triangles_out = 0;  ///< over the simplified meshes
  nlohmann::json info;                  ///< /robot/info.json
};

/// Writes the display description of `robot` and prepares its meshes. Throws mesh::MeshError naming
/// a mesh file that cannot be read.
DisplayRobot display_robot(const model::RobotSpec& robot, const DisplayOptions& options = {});

/// The box of uniform density with the link's mass and inertia about its centre of mass (its
/// physically consistent one), at the centre of mass along the principal axes: how a link without
/// any geometry is drawn.
model::Geometry inertia_box(const model::LinkDesc& link);

/// Roll, pitch, yaw of a rotation, URDF convention R = Rz(yaw) Ry(pitch) Rx(roll).
model::Vector3d rpy_of(const model::Matrix3d& R);

}  // namespace hpr::viewer
