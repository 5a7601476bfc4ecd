#include "hpr/model/mesh_path.hpp"

#include <fmt/format.h>
#include <tinyxml.h>

#include <cstdlib>
#include <set>
#include <sstream>
#include <string_view>

#include "hpr/model/urdf.hpp"

namespace hpr::model {

namespace fs = std::filesystem;

std::vector<fs::path> mesh_search_dirs(const std::vector<std::string>& configured) {
  std::vector<fs::path> dirs(configured.begin(), configured.end());
  for (const char* var : {"HPR_MESH_PATH", "ROS_PACKAGE_PATH"}) {
    const char* v = std::getenv(var);
    if (v == nullptr) continue;
    std::stringstream ss(v);
    std::string item;
    while (std::getline(ss, item, ':')) {
      if (!item.empty()) dirs.emplace_back(item);
    }
  }
  return dirs;
}

std::string package_name(const fs::path& manifest) {
  std::error_code ec;
  if (!fs::is_regular_file(manifest, ec)) return {};
  TiXmlDocument doc(manifest.string());
  if (!doc.LoadFile()) return {};
  const TiXmlElement* root = doc.RootElement();
  if (root == nullptr || std::string_view(root->Value()) != "package") return {};
  const TiXmlElement* name = root->FirstChildElement("name");
  if (name == nullptr || name->GetText() == nullptr) return {};
  std::string n = name->GetText();
  const auto first = n.find_first_not_of(" \t\r\n");
  const auto last = n.find_last_not_of(" \t\r\n");
  return first == std::string::npos ? std::string{} : n.substr(first, last - first + 1);
}

namespace {

/// Folders under `dir` (itself included, `depth` levels down) whose package.xml declares `package`.
void find_packages(const fs::path& dir, const std::string& package, int depth, std::vector<fs::path>& out) {
  std::error_code ec;
  if (package_name(dir / "package.xml") == package) out.push_back(dir);
  if (depth == 0 || !fs::is_directory(dir, ec)) return;
  for (fs::directory_iterator it(dir, fs::directory_options::skip_permission_denied, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (name.empty() || name[0] == '.' || !it->is_directory(ec)) continue;
    find_packages(it->path(), package, depth - 1, out);
  }
}

/// The URDF's folder and its ancestors, up to the repository root (the first holding `.git`) or the
/// file system's root.
std::vector<fs::path> ancestors(const fs::path& urdf_dir) {
  std::vector<fs::path> out;
  std::error_code ec;
  for (fs::path d = urdf_dir; !d.empty(); d = d.parent_path()) {
    out.push_back(d);
    if (fs::exists(d / ".git", ec) || d == d.root_path()) break;
  }
  return out;
}

}  // namespace

std::string resolve_mesh(const std::string& uri, const std::string& urdf_path, const std::string& link,
                         const std::vector<fs::path>& search) {
  std::error_code ec;
  const fs::path urdf_dir = fs::absolute(fs::path(urdf_path), ec).parent_path();
  std::vector<fs::path> candidates;
  constexpr std::string_view kPackage = "package://", kFile = "file://";
  if (uri.rfind(kPackage, 0) == 0) {
    std::string rest = uri.substr(kPackage.size());
    rest.erase(0, rest.find_first_not_of('/'));  // package:///NAME/... as some models write it
    const auto slash = rest.find('/');
    const std::string package = rest.substr(0, slash);
    const std::string inside = slash == std::string::npos ? "" : rest.substr(slash + 1);
    const std::vector<fs::path> up = ancestors(urdf_dir);
    // 1. The folder whose manifest names the package.
    std::vector<fs::path> packages;
    for (const auto& d : up) {
      if (package_name(d / "package.xml") == package) packages.push_back(d);
    }
    for (const auto& s : search) find_packages(s, package, 3, packages);
    for (const auto& p : packages) candidates.push_back(p / inside);
    // 2. A folder called after the package.
    for (const auto& d : up) {
      if (d.filename() == package) candidates.push_back(d / inside);
      candidates.push_back(d / package / inside);
    }
    for (const auto& s : search) candidates.push_back(s / package / inside);
    // 3. The path inside the package from each ancestor up to the repository root, then each search folder.
    for (const auto& d : up) candidates.push_back(d / inside);
    for (const auto& s : search) candidates.push_back(s / inside);
  } else if (uri.rfind(kFile, 0) == 0) {
    candidates.emplace_back(uri.substr(kFile.size()));
  } else if (fs::path(uri).is_absolute()) {
    candidates.emplace_back(uri);
  } else {
    candidates.push_back(urdf_dir / uri);
    for (const auto& s : search) candidates.push_back(s / uri);
  }
  std::set<std::string> seen;
  std::string looked;
  for (const auto& c : candidates) {
    if (fs::is_regular_file(c, ec)) return fs::weakly_canonical(c, ec).string();
    const std::string shown = c.lexically_normal().string();
    if (seen.insert(shown).second) looked += fmt::format("\n  {}", shown);
  }
  throw ModelError(fmt::format("{}: link '{}': mesh '{}' not found; looked for:{}\nadd the folder that holds it (or its package) "
                               "with --mesh-path DIR (hpr_robot), robot.mesh_search_paths in the configuration, or HPR_MESH_PATH",
                               urdf_path, link, uri, looked));
}

}  // namespace hpr::model
