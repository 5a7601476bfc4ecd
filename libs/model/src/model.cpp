#include "hpr/model/model.hpp"

#include <fmt/format.h>

#include <Eigen/Eigenvalues>

#include <cmath>
#include <functional>
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

Model Model::build(const RobotDescription& d, const ModelOptions& options) {
  Model m;
  m.source = d.source;
  for (const auto& [name, q] : options.held) {
    if (const std::string why = check_held_joint(d, name, q); !why.empty()) {
      throw ModelError(fmt::format("{}: held joint '{}': {}", d.source, name, why));
    }
  }
  // The fixed position of a held or locked joint, or NaN for a joint of the model.
  std::function<double(const JointDesc&, int)> fixed_position = [&](const JointDesc& j, int depth) -> double {
    if (auto it = options.held.find(j.name); it != options.held.end()) return it->second;
    if (j.mimic.empty() || depth > 32) return std::numeric_limits<double>::quiet_NaN();
    const JointDesc* leader = d.find_joint(j.mimic);
    double q_leader = leader != nullptr ? fixed_position(*leader, depth + 1) : 0.0;
    if (std::isnan(q_leader)) {
      const auto it = options.leader_positions.find(j.mimic);
      q_leader = it != options.leader_positions.end() ? it->second : 0.0;
    }
    return j.mimic_multiplier * q_leader + j.mimic_offset;
  };
  std::string base = options.base_link;
  if (base.empty()) {
    base = d.root_link;
    // A floating joint from a massless root ("world") to the real base.
    for (const JointDesc* j : d.child_joints(d.root_link)) {
      if (j->type == JointType::kFloating) base = j->child;
    }
  }
  if (d.find_link(base) == nullptr) {
    throw ModelError(fmt::format("{}: base link '{}' does not exist", d.source, base));
  }
  if (base != d.root_link) {
    // Everything above the base must be massless (a world link and a floating joint).
    const LinkDesc* root = d.find_link(d.root_link);
    if (root->has_inertial && root->mass > 0) {
      throw ModelError(fmt::format("{}: the base '{}' is not the URDF root, and the root '{}' has mass", d.source,
                                   base, d.root_link));
    }
  }

  m.body_name = {base};
  m.parent = {-1};
  m.kind = {JointKind::kFreeFlyer};
  m.X_PJ = {SE3::Identity()};
  m.axis = {Vector3d::Zero()};
  m.inertia = {Inertia{}};
  m.support = {{}};
  std::vector<std::string> moved_by = {"(floating base)"};
  std::vector<Inertia> physical = {Inertia{}};  // the same bodies with the physical inertias

  // Depth-first walk; fixed joints merge the child link into the current body.
  std::function<void(const std::string&, int, const SE3&)> walk = [&](const std::string& link, int body,
                                                                      const SE3& X_BL) {
    const LinkDesc* ld = d.find_link(link);
    m.inertia[static_cast<size_t>(body)] += link_inertia(*ld, options.physical_inertia).transformed(X_BL);
    physical[static_cast<size_t>(body)] += link_inertia(*ld, true).transformed(X_BL);
    m.frames.push_back(Frame{link, body, X_BL});
    for (const JointDesc* j : d.child_joints(link)) {
      const SE3 X_BJ = X_BL * j->X_PJ;
      if (j->type == JointType::kFixed) {
        walk(j->child, body, X_BJ);
        continue;
      }
      if (const double q_fixed = fixed_position(*j, 0); !std::isnan(q_fixed)) {
        const bool held = options.held.count(j->name) != 0;
        (held ? m.held_joint_name : m.locked_joint_name).push_back(j->name);
        (held ? m.held_q : m.locked_q).push_back(q_fixed);
        if (!held) {
          m.warnings.push_back(fmt::format("joint '{}' mimics '{}' and is locked at {:.4g} (its position with the "
                                           "leader at {})", j->name, j->mimic, q_fixed,
                                           options.held.count(j->mimic) || options.leader_positions.count(j->mimic)
                                               ? "its held position"
                                               : "zero"));
        }
        walk(j->child, body, X_BJ * joint_motion(*j, q_fixed));
        continue;
      }
      if (j->type == JointType::kFloating || j->type == JointType::kPlanar) {
        throw ModelError(fmt::format("{}: joint '{}' below the base is {}; only the base floats", d.source, j->name,
                                     j->type == JointType::kFloating ? "floating" : "planar"));
      }
      const int child = static_cast<int>(m.body_name.size());
      m.body_name.push_back(j->child);
      m.parent.push_back(body);
      m.kind.push_back(j->type == JointType::kPrismatic ? JointKind::kPrismatic : JointKind::kRevolute);
      m.X_PJ.push_back(X_BJ);
      m.axis.push_back(j->axis.normalized());
      m.inertia.emplace_back();
      physical.emplace_back();
      auto sup = m.support[static_cast<size_t>(body)];
      sup.push_back(child - 1);
      m.support.push_back(sup);
      moved_by.push_back(j->name);
      m.joint_name.push_back(j->name);
      const bool continuous = j->type == JointType::kContinuous;
      m.q_lower.push_back(continuous || !j->has_limits ? -kInf : j->lower);
      m.q_upper.push_back(continuous || !j->has_limits ? kInf : j->upper);
      m.v_max.push_back(j->has_limits && j->velocity > 0 ? j->velocity : kInf);
      m.tau_max.push_back(j->has_limits && j->effort > 0 ? j->effort : kInf);
      m.damping.push_back(j->damping);
      m.friction.push_back(j->friction);
      walk(j->child, child, SE3::Identity());
    }
  };
  walk(base, 0, SE3::Identity());

  // A body that the file's inertias leave without a positive-definite inertia (a point mass on its
  // own) takes the physical one: the dynamics need it.
  for (size_t i = 0; i < m.inertia.size(); ++i) {
    Inertia& I = m.inertia[i];
    if (options.physical_inertia || !(I.m > 0.0) || positive_definite(I.inertia_about_com())) continue;
    if (positive_definite(physical[i].inertia_about_com())) {
      m.warnings.push_back(fmt::format("body '{}': its inertia from the file is singular; the controllers' model "
                                       "uses the regularised one", m.body_name[i]));
      I = physical[i];
    }
  }
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
  for (int i = 0; i < m.nb; ++i) {
    const Inertia& I = m.inertia[static_cast<size_t>(i)];
    if (!(I.m > 0.0)) {
      throw ModelError(fmt::format("{}: link '{}' is moved by joint '{}' but has no inertia (no <inertial> on it "
                                   "or on a link fixed to it)",
                                   d.source, m.body_name[static_cast<size_t>(i)], moved_by[static_cast<size_t>(i)]));
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
