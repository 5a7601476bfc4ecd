#include "hpr/model/model.hpp"

#include <fmt/format.h>

#include <Eigen/Eigenvalues>

#include <cmath>
#include <limits>

namespace hpr::model {

namespace {
constexpr double kInf = std::numeric_limits<double>::infinity();

Inertia link_inertia(const LinkDesc& l, bool physical) {
  if (!l.has_inertial) return {};
  return Inertia::from_com(l.mass, l.com, physical ? l.inertia_physical : l.inertia);
}

bool positive_definite(const Matrix3d& I) {
  return Eigen::SelfAdjointEigenSolver<Matrix3d>(0.5 * (I + I.transpose())).eigenvalues()(0) > 0.0;
}

// The placement a joint of the description adds at position q.
SE3 joint_motion(const JointDesc& j, double q) {
  SE3 X = SE3::Identity();
  if (j.type == JointType::kPrismatic) {
    X.p = q * j.axis.normalized();
  } else if (j.type == JointType::kRevolute || j.type == JointType::kContinuous) {
    X.R = Eigen::AngleAxisd(q, j.axis.normalized()).toRotationMatrix();
  }
  return X;
}
}  // namespace

std::string check_held_joint(const RobotDescription& d, const std::string& name, double q) {
  const JointDesc* j = d.find_joint(name);
  if (j == nullptr) return "not a joint of the URDF";
  if (j->type == JointType::kFixed || j->type == JointType::kFloating || j->type == JointType::kPlanar) {
    return "does not move (it is not revolute, continuous or prismatic)";
  }
  if (!j->mimic.empty()) return fmt::format("mimics '{}' and is locked with it; hold '{}' instead", j->mimic, j->mimic);
  if (!std::isfinite(q) || (j->has_limits && j->type != JointType::kContinuous && (q < j->lower || q > j->upper))) {
    return fmt::format("position {} is outside its limits [{}, {}]", q, j->lower, j->upper);
  }
  return "";
}

Model Model::build(const RobotDescription& d, const std::string& base_link_in) {
  ModelOptions options;
  options.base_link = base_link_in;
  return build(d, options);
}

namespace {

/// The base link: the given one, else the URDF's root (or the child of a floating joint from a
/// massless root, "world"). Everything above it must be massless.
std::string base_link(const RobotDescription& d, const ModelOptions& options) {
  std::string base = options.base_link;
  if (base.empty()) {
    base = d.root_link;
    for (const JointDesc* j : d.child_joints(d.root_link)) {
      if (j->type == JointType::kFloating) base = j->child;
    }
  }
  if (d.find_link(base) == nullptr) {
    throw ModelError(fmt::format("{}: base link '{}' does not exist", d.source, base));
  }
  if (base != d.root_link) {
    const LinkDesc* root = d.find_link(d.root_link);
    if (root->has_inertial && root->mass > 0) {
      throw ModelError(fmt::format("{}: the base '{}' is not the URDF root, and the root '{}' has mass", d.source,
                                   base, d.root_link));
    }
  }
  return base;
}

/// The kinematic tree from the description: a depth-first walk in which fixed, held and locked
/// (mimic) joints merge their child link into the current body.
class TreeBuilder {
 public:
  TreeBuilder(const RobotDescription& d, const ModelOptions& options, Model& m) : d_(d), options_(options), m_(m) {}

  void build(const std::string& base) {
    m_.body_name = {base};
    m_.parent = {-1};
    m_.kind = {JointKind::kFreeFlyer};
    m_.X_PJ = {SE3::Identity()};
    m_.axis = {Vector3d::Zero()};
    m_.inertia = {Inertia{}};
    m_.support = {{}};
    walk(base, 0, SE3::Identity());
  }

  std::vector<std::string> moved_by = {"(floating base)"};  ///< the joint that moves each body
  std::vector<Inertia> physical = {Inertia{}};              ///< the same bodies with the physical inertias

 private:
  /// The fixed position of a held or locked joint, or NaN for a joint of the model.
  double fixed_position(const JointDesc& j, int depth) const {
    if (auto it = options_.held.find(j.name); it != options_.held.end()) return it->second;
    if (j.mimic.empty() || depth > 32) return std::numeric_limits<double>::quiet_NaN();
    const JointDesc* leader = d_.find_joint(j.mimic);
    double q_leader = leader != nullptr ? fixed_position(*leader, depth + 1) : 0.0;
    if (std::isnan(q_leader)) {
      const auto it = options_.leader_positions.find(j.mimic);
      q_leader = it != options_.leader_positions.end() ? it->second : 0.0;
    }
    return j.mimic_multiplier * q_leader + j.mimic_offset;
  }

  void walk(const std::string& link, int body, const SE3& X_BL) {
    const LinkDesc* ld = d_.find_link(link);
    m_.inertia[static_cast<size_t>(body)] += link_inertia(*ld, options_.physical_inertia).transformed(X_BL);
    physical[static_cast<size_t>(body)] += link_inertia(*ld, true).transformed(X_BL);
    m_.frames.push_back(Frame{link, body, X_BL});
    for (const JointDesc* j : d_.child_joints(link)) {
      const SE3 X_BJ = X_BL * j->X_PJ;
      if (j->type == JointType::kFixed) {
        walk(j->child, body, X_BJ);
        continue;
      }
      if (const double q_fixed = fixed_position(*j, 0); !std::isnan(q_fixed)) {
        hold(*j, q_fixed);
        walk(j->child, body, X_BJ * joint_motion(*j, q_fixed));
        continue;
      }
      if (j->type == JointType::kFloating || j->type == JointType::kPlanar) {
        throw ModelError(fmt::format("{}: joint '{}' below the base is {}; only the base floats", d_.source, j->name,
                                     j->type == JointType::kFloating ? "floating" : "planar"));
      }
      walk(j->child, add_body(*j, body, X_BJ), SE3::Identity());
    }
  }

  /// A held joint, or a locked mimic one (said in the warnings), at its fixed position.
  void hold(const JointDesc& j, double q_fixed) {
    const bool held = options_.held.count(j.name) != 0;
    (held ? m_.held_joint_name : m_.locked_joint_name).push_back(j.name);
    (held ? m_.held_q : m_.locked_q).push_back(q_fixed);
    if (!held) {
      m_.warnings.push_back(fmt::format("joint '{}' mimics '{}' and is locked at {:.4g} (its position with the "
                                        "leader at {})", j.name, j.mimic, q_fixed,
                                        options_.held.count(j.mimic) || options_.leader_positions.count(j.mimic)
                                            ? "its held position"
                                            : "zero"));
    }
  }

  /// A body moved by joint `j` below `body`; its index.
  int add_body(const JointDesc& j, int body, const SE3& X_BJ) {
    const int child = static_cast<int>(m_.body_name.size());
    m_.body_name.push_back(j.child);
    m_.parent.push_back(body);
    m_.kind.push_back(j.type == JointType::kPrismatic ? JointKind::kPrismatic : JointKind::kRevolute);
    m_.X_PJ.push_back(X_BJ);
    m_.axis.push_back(j.axis.normalized());
    m_.inertia.emplace_back();
    physical.emplace_back();
    auto sup = m_.support[static_cast<size_t>(body)];
    sup.push_back(child - 1);
    m_.support.push_back(sup);
    moved_by.push_back(j.name);
    m_.joint_name.push_back(j.name);
    const bool continuous = j.type == JointType::kContinuous;
    m_.q_lower.push_back(continuous || !j.has_limits ? -kInf : j.lower);
    m_.q_upper.push_back(continuous || !j.has_limits ? kInf : j.upper);
    m_.v_max.push_back(j.has_limits && j.velocity > 0 ? j.velocity : kInf);
    m_.tau_max.push_back(j.has_limits && j.effort > 0 ? j.effort : kInf);
    m_.damping.push_back(j.damping);
    m_.friction.push_back(j.friction);
    return child;
  }

  const RobotDescription& d_;
  const ModelOptions& options_;
  Model& m_;
};

/// The sizes, subtree sizes and the per-body data the algorithms read (axis codes, placements that
/// rotate, centres of mass and inertias about them).
void derive_body_data(Model& m) {
  m.nb = static_cast<int>(m.body_name.size());
  m.nj = m.nb - 1;
  m.nq = 7 + m.nj;
  m.nv = 6 + m.nj;
  m.subtree_size.assign(static_cast<size_t>(m.nb), 1);
  for (int i = m.nb - 1; i > 0; --i) m.subtree_size[static_cast<size_t>(m.parent[static_cast<size_t>(i)])] += m.subtree_size[static_cast<size_t>(i)];
  for (int i = 0; i < m.nb; ++i) {
    const Vector3d& a = m.axis[static_cast<size_t>(i)];
    int code = 0;
    for (int k = 0; k < 3; ++k) {
      if (std::abs(std::abs(a(k)) - 1.0) < 1e-15 && std::abs(a((k + 1) % 3)) == 0.0 && std::abs(a((k + 2) % 3)) == 0.0) {
        code = a(k) > 0 ? k + 1 : -(k + 1);
      }
    }
    m.axis_code.push_back(i == 0 ? 0 : code);
    m.placement_rotates.push_back(m.X_PJ[static_cast<size_t>(i)].R.isIdentity(0.0) ? 0 : 1);
    m.com_body.push_back(m.inertia[static_cast<size_t>(i)].com());
    m.inertia_com_body.push_back(m.inertia[static_cast<size_t>(i)].inertia_about_com());
  }
}

}  // namespace

Model Model::build(const RobotDescription& d, const ModelOptions& options) {
  Model m;
  m.source = d.source;
  for (const auto& [name, q] : options.held) {
    if (const std::string why = check_held_joint(d, name, q); !why.empty()) {
      throw ModelError(fmt::format("{}: held joint '{}': {}", d.source, name, why));
    }
  }
  TreeBuilder tree(d, options, m);
  tree.build(base_link(d, options));

  // A body that the file's inertias leave without a positive-definite inertia (a point mass on its
  // own) takes the physical one: the dynamics need it.
  for (size_t i = 0; i < m.inertia.size(); ++i) {
    Inertia& I = m.inertia[i];
    if (options.physical_inertia || !(I.m > 0.0) || positive_definite(I.inertia_about_com())) continue;
    if (positive_definite(tree.physical[i].inertia_about_com())) {
      m.warnings.push_back(fmt::format("body '{}': its inertia from the file is singular; the controllers' model "
                                       "uses the regularised one", m.body_name[i]));
      I = tree.physical[i];
    }
  }
  derive_body_data(m);
  for (int i = 0; i < m.nb; ++i) {
    const Inertia& I = m.inertia[static_cast<size_t>(i)];
    if (!(I.m > 0.0)) {
      throw ModelError(fmt::format("{}: link '{}' is moved by joint '{}' but has no inertia (no <inertial> on it "
                                   "or on a link fixed to it)",
                                   d.source, m.body_name[static_cast<size_t>(i)], tree.moved_by[static_cast<size_t>(i)]));
    }
    if (!positive_definite(I.inertia_about_com())) {
      throw ModelError(fmt::format("{}: body '{}' (with the links fixed to it): inertia {}", d.source,
                                   m.body_name[static_cast<size_t>(i)], check_inertia(I.inertia_about_com())));
    }
    m.mass += I.m;
  }
  return m;
}

void Model::set_inertia(int body, const Inertia& I) {
  const auto b = static_cast<size_t>(body);
  mass += I.m - inertia.at(b).m;
  inertia[b] = I;
  com_body.at(b) = I.com();
  inertia_com_body.at(b) = I.inertia_about_com();
}

Model Model::from_urdf(const std::string& path, const std::string& base_link) {
  return build(load_urdf(path), base_link);
}

int Model::joint_index(const std::string& name) const {
  for (int j = 0; j < nj; ++j) {
    if (joint_name[static_cast<size_t>(j)] == name) return j;
  }
  throw ModelError(fmt::format("{}: no actuated joint named '{}'", source, name));
}

int Model::body_index(const std::string& name) const {
  for (int b = 0; b < nb; ++b) {
    if (body_name[static_cast<size_t>(b)] == name) return b;
  }
  throw ModelError(fmt::format("{}: no moving body named '{}'", source, name));
}

bool Model::has_frame(const std::string& name) const {
  for (const auto& f : frames) {
    if (f.name == name) return true;
  }
  return false;
}

int Model::frame_index(const std::string& name) const {
  for (size_t i = 0; i < frames.size(); ++i) {
    if (frames[i].name == name) return static_cast<int>(i);
  }
  throw ModelError(fmt::format("{}: no frame (link) named '{}'", source, name));
}

int Model::add_frame(const std::string& name, const std::string& parent_frame, const SE3& X_PF) {
  if (has_frame(name)) throw ModelError(fmt::format("{}: frame '{}' exists already", source, name));
  const Frame& p = frames[static_cast<size_t>(frame_index(parent_frame))];
  frames.push_back(Frame{name, p.body, p.X_BF * X_PF});
  return static_cast<int>(frames.size()) - 1;
}

Eigen::VectorXd Model::neutral() const {
  Eigen::VectorXd q = Eigen::VectorXd::Zero(nq);
  q(6) = 1.0;  // quaternion w
  for (int j = 0; j < nj; ++j) {
    const double lo = q_lower[static_cast<size_t>(j)], hi = q_upper[static_cast<size_t>(j)];
    if (lo > 0.0 || hi < 0.0) q(7 + j) = 0.5 * (lo + hi);
  }
  return q;
}

Data::Data(const Model& model)
    : oMi(static_cast<size_t>(model.nb)),
      oMf(model.frames.size()),
      S(static_cast<size_t>(model.nb), Vector6d::Zero()),
      S0(Eigen::Matrix<double, 6, 6>::Zero()),
      vel(static_cast<size_t>(model.nb), Vector6d::Zero()),
      Iw(static_cast<size_t>(model.nb)),
      Yc(static_cast<size_t>(model.nb)),
      M(Eigen::MatrixXd::Zero(model.nv, model.nv)),
      nle(Eigen::VectorXd::Zero(model.nv)),
      g(Eigen::VectorXd::Zero(model.nv)),
      tau(Eigen::VectorXd::Zero(model.nv)),
      acc(static_cast<size_t>(model.nb), Vector6d::Zero()),
      f(static_cast<size_t>(model.nb), Vector6d::Zero()),
      F(static_cast<size_t>(model.nb), Vector6d::Zero()),
      mass(model.mass),
      Ag(Matrix6Xd::Zero(6, model.nv)),
      Jcom(Matrix3Xd::Zero(3, model.nv)),
      J(Matrix6Xd::Zero(6, model.nv)),
      v_r(Eigen::VectorXd::Zero(model.nv)),
      a_r(Eigen::VectorXd::Zero(model.nv)),
      y(Eigen::VectorXd::Zero(model.nv)) {}

}  // namespace hpr::model
