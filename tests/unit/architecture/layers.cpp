#include "layers.hpp"

#include <algorithm>
#include <fstream>
#include <functional>
#include <regex>
#include <set>
#include <stdexcept>

namespace hpr::arch {

namespace fs = std::filesystem;

std::map<std::string, int> read_layers(const fs::path& document) {
  std::ifstream in(document);
  if (!in) throw std::runtime_error("cannot read " + document.string());
  static const std::regex row(R"(^\|\s*(\d+)\s*\|([^|]*)\|)");
  static const std::regex folder("`([^`]+)`");
  std::map<std::string, int> layers;
  std::string line;
  while (std::getline(in, line)) {
    std::smatch m;
    if (!std::regex_search(line, m, row)) continue;
    const int layer = std::stoi(m[1].str());
    const std::string cell = m[2].str();
    for (auto it = std::sregex_iterator(cell.begin(), cell.end(), folder); it != std::sregex_iterator(); ++it) {
      layers[(*it)[1].str()] = layer;
    }
  }
  if (layers.empty()) throw std::runtime_error(document.string() + ": no layer table (rows '| N | `folder` | ... |')");
  return layers;
}

std::string folder_of(const std::string& path, const std::map<std::string, int>& layers) {
  std::string best;
  for (const auto& [f, layer] : layers) {
    if ((path == f || path.rfind(f + "/", 0) == 0) && f.size() > best.size()) best = f;
  }
  return best;
}

namespace {

bool skipped_directory(const fs::path& p) {
  const std::string name = p.filename().string();
  return name == ".git" || name == "node_modules" || name.rfind("build", 0) == 0;
}

bool cpp_file(const fs::path& p) {
  const std::string ext = p.extension().string();
  return ext == ".cpp" || ext == ".hpp" || ext == ".h" || ext == ".cc" || ext == ".cxx";
}

std::vector<fs::path> cpp_files(const fs::path& root) {
  std::vector<fs::path> out;
  for (auto it = fs::recursive_directory_iterator(root); it != fs::recursive_directory_iterator(); ++it) {
    if (it->is_directory() && skipped_directory(it->path())) {
      it.disable_recursion_pending();
      continue;
    }
    if (it->is_regular_file() && cpp_file(it->path())) out.push_back(it->path());
  }
  std::sort(out.begin(), out.end());
  return out;
}

}  // namespace

Report scan(const fs::path& root, const std::map<std::string, int>& layers) {
  Report r;
  const std::vector<fs::path> files = cpp_files(root);
  // Which folder provides each header "hpr/...": the folder of the include/ that holds it.
  std::map<std::string, std::string> provider;
  for (const fs::path& p : files) {
    const std::string rel = fs::relative(p, root).generic_string();
    const auto at = rel.find("include/hpr/");
    if (at != std::string::npos) provider[rel.substr(at + 8)] = folder_of(rel, layers);
  }
  static const std::regex include(R"(^\s*#\s*include\s*[<"]([^>"]+)[>"])");
  for (const fs::path& p : files) {
    const std::string rel = fs::relative(p, root).generic_string();
    const std::string from = folder_of(rel, layers);
    if (from.empty()) {
      r.unplaced.push_back(rel);
      continue;
    }
    std::ifstream in(p);
    std::string line;
    for (int n = 1; std::getline(in, line); ++n) {
      std::smatch m;
      if (!std::regex_search(line, m, include)) continue;
      const std::string header = m[1].str();
      std::string to;
      if (header.rfind("humanoid/", 0) == 0) {
        to = layers.count("lcmtypes") != 0 ? "lcmtypes" : "";
      } else if (const auto it = provider.find(header); it != provider.end()) {
        to = it->second;
      } else if (fs::exists(p.parent_path() / header)) {
        to = folder_of(fs::relative(fs::weakly_canonical(p.parent_path() / header), fs::weakly_canonical(root)).generic_string(), layers);
      }
      if (!to.empty() && to != from) r.edges.push_back({from, to, rel, n, header});
    }
  }
  for (const auto& [f, layer] : layers) {
    if (!fs::is_directory(root / f)) r.missing.push_back(f);
  }
  return r;
}

namespace {

/// The cycles of the folder graph: one line per strongly connected component of more than one
/// folder (Tarjan), its folders in order.
std::vector<std::string> cycles(const std::vector<Edge>& edges) {
  std::map<std::string, std::set<std::string>> next;
  for (const Edge& e : edges) next[e.from].insert(e.to), next[e.to];
  std::map<std::string, int> index, low;
  std::vector<std::string> stack;
  std::set<std::string> on_stack;
  std::vector<std::string> out;
  int counter = 0;
  std::function<void(const std::string&)> visit = [&](const std::string& v) {
    index[v] = low[v] = counter++;
    stack.push_back(v);
    on_stack.insert(v);
    for (const std::string& w : next[v]) {
      if (index.count(w) == 0) {
        visit(w);
        low[v] = std::min(low[v], low[w]);
      } else if (on_stack.count(w) != 0) {
        low[v] = std::min(low[v], index[w]);
      }
    }
    if (low[v] != index[v]) return;
    std::vector<std::string> component;
    std::string w;
    do {
      w = stack.back();
      stack.pop_back();
      on_stack.erase(w);
      component.push_back(w);
    } while (w != v);
    if (component.size() < 2) return;
    std::sort(component.begin(), component.end());
    std::string text = "cycle between folders:";
    for (const std::string& c : component) text += " " + c;
    out.push_back(text);
  };
  for (const auto& [v, unused] : next) {
    if (index.count(v) == 0) visit(v);
  }
  return out;
}

}  // namespace

std::vector<std::string> violations(const Report& r, const std::map<std::string, int>& layers) {
  std::vector<std::string> out;
  for (const Edge& e : r.edges) {
    const int a = layers.at(e.from), b = layers.at(e.to);
    if (b < a) continue;
    out.push_back(e.file + ":" + std::to_string(e.line) + ": " + e.from + " (layer " + std::to_string(a) + ") includes " + e.header + " of " +
                  e.to + " (layer " + std::to_string(b) + (b == a ? ", the same" : ", above") + ")");
  }
  for (const std::string& c : cycles(r.edges)) out.push_back(c);
  for (const std::string& f : r.unplaced) out.push_back(f + ": in no folder of the layer table");
  for (const std::string& f : r.missing) out.push_back(f + ": a folder of the layer table that the tree does not have");
  return out;
}

std::map<std::string, int> read_size_limits(const fs::path& document) {
  std::ifstream in(document);
  if (!in) throw std::runtime_error("cannot read " + document.string());
  static const std::regex row(R"(^\|\s*`([^`]+)`\s*\|\s*(\d+)\s*\|)");
  std::map<std::string, int> limits;
  std::string line;
  while (std::getline(in, line)) {
    std::smatch m;
    if (std::regex_search(line, m, row)) limits[m[1].str()] = std::stoi(m[2].str());
  }
  return limits;
}

std::vector<std::string> oversized(const fs::path& root, const std::map<std::string, int>& limits) {
  std::vector<std::string> out;
  for (const auto& [folder, most] : limits) {
    if (!fs::is_directory(root / folder)) {
      out.push_back(folder + ": in the size table, not in the tree");
      continue;
    }
    for (const fs::path& file : cpp_files(root / folder)) {
      std::ifstream in(file);
      int lines = 0;
      for (std::string l; std::getline(in, l);) ++lines;
      if (lines > most) {
        out.push_back(fs::relative(file, root).generic_string() + ": " + std::to_string(lines) + " lines, at most " + std::to_string(most));
      }
    }
  }
  return out;
}

}  // namespace hpr::arch
