#pragma once
/// \file
/// What the browser needs to draw a robot: a URDF for display written from the loaded description
/// (every mesh renamed to a URL the viewer serves; links without visual geometry drawn with their
/// collision geometry; `<mimic>` kept so followers move with their leaders), the mesh files behind
/// the URLs, and a JSON summary (base link, feet and soles, held and locked joints).

#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "hpr/model/robot.hpp"

namespace hpr::viewer {

struct DisplayRobot {
  std::string urdf;                     ///< URDF text for urdf-loader
  std::vector<std::string> mesh_files;  ///< file behind /robot/mesh/<i>.<ext>
  std::vector<std::string> mesh_urls;   ///< "/robot/mesh/<i>.<ext>"
  nlohmann::json info;                  ///< /robot/info.json
};

/// Writes the display description of `robot`.
DisplayRobot display_robot(const model::RobotSpec& robot);

/// Roll, pitch, yaw of a rotation, URDF convention R = Rz(yaw) Ry(pitch) Rx(roll).
model::Vector3d rpy_of(const model::Matrix3d& R);

}  // namespace hpr::viewer
