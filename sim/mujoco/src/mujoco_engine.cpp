// The MuJoCo engine: the simulated model written as an MJCF model (bodies in the model's body
// frames, the inertias, the joints and their limits, the collision shapes that the Bullet engine
// gets too, a ground plane), compiled in memory and stepped by mj_step.
#include <fmt/format.h>
#include <mujoco/mujoco.h>

#include <Eigen/Geometry>
#include <cmath>
#include <cstring>
#include <fstream>
#include <memory>
#include <sstream>
#include <stdexcept>

#include "hpr/common/text.hpp"
#include "hpr/sim/mujoco_engine.hpp"
#include "hpr/sim/simulator.hpp"

namespace hpr::sim {
namespace {

using Eigen::Matrix3d;
using Eigen::Vector3d;
using model::SE3;
using model::Vector6d;

std::string vec(const Vector3d& v) { return fmt::format("{:.17g} {:.17g} {:.17g}", v.x(), v.y(), v.z()); }

std::string quat(const Matrix3d& R) {
  const Eigen::Quaterniond q(R);
  return fmt::format("{:.17g} {:.17g} {:.17g} {:.17g}", q.w(), q.x(), q.y(), q.z());
}

/// The MJCF text of the simulated model `m` with the collision `shapes` of each body.
class MjcfWriter {
 public:
  MjcfWriter(const model::Model& m, const SimConfig& c, const std::vector<std::vector<CollisionShape>>& shapes)
      : m_(m), c_(c), shapes_(shapes) {}

  std::string write() {
    const MujocoConfig& mj = c_.mujoco;
    const double h = c_.dt / c_.substeps;
    std::ostringstream body;
    write_body(0, body, 2);
    std::ostringstream x;
    x << "<mujoco model=\"" << xml_escape(m_.body_name[0]) << "\">\n"
      << "  <compiler angle=\"radian\" inertiafromgeom=\"false\"/>\n"
      << fmt::format("  <option timestep=\"{:.17g}\" gravity=\"{}\" iterations=\"{}\" cone=\"{}\" integrator=\"{}\" "
                     "impratio=\"{:.17g}\" noslip_iterations=\"{}\"/>\n",
                     h, vec(c_.gravity), c_.solver_iterations, mj.elliptic_cone ? "elliptic" : "pyramidal",
                     mj.implicit ? "implicit" : "Euler", mj.impratio, mj.noslip_iterations)
      << "  <size njmax=\"2000\" nconmax=\"400\"/>\n"
      // Joint limits as stiff as the contacts (MuJoCo's default time constant, 20 ms, lets a joint
      // pressed against its limit by a few tens of Nm pass it by a few centiradians).
      << fmt::format("  <default><joint solreflimit=\"{:.17g} {:.17g}\"/><geom condim=\"{}\" friction=\"{:.17g} {:.17g} {:.17g}\" solref=\"{:.17g} {:.17g}\" "
                     "contype=\"1\" conaffinity=\"0\"/></default>\n",
                     mj.timeconst, mj.dampratio, mj.condim, c_.ground_friction, mj.torsional_friction, mj.rolling_friction, mj.timeconst, mj.dampratio)
      << "  <asset>\n" << assets_.str() << "  </asset>\n"
      << "  <worldbody>\n"
      << "    <geom name=\"ground\" type=\"plane\" size=\"0 0 1\" contype=\"0\" conaffinity=\"1\"/>\n"
      << body.str() << "  </worldbody>\n</mujoco>\n";
    return x.str();
  }

 private:
  void write_body(int b, std::ostringstream& o, int indent) {
    const std::string pad(static_cast<std::size_t>(indent) * 2, ' ');
    const auto bu = static_cast<std::size_t>(b);
    const SE3& X_PJ = m_.X_PJ[bu];
    o << pad << "<body name=\"" << xml_escape(m_.body_name[bu]) << "\"";
    if (b != 0) o << " pos=\"" << vec(X_PJ.p) << "\" quat=\"" << quat(X_PJ.R) << "\"";
    o << ">\n";
    if (b == 0) {
      o << pad << "  <freejoint name=\"" << xml_escape(m_.body_name[0]) << "_floating\"/>\n";
    } else {
      const int j = b - 1;
      const auto ju = static_cast<std::size_t>(j);
      o << pad << "  <joint name=\"" << xml_escape(m_.joint_name[ju]) << "\" type=\""
        << (m_.kind[bu] == model::JointKind::kPrismatic ? "slide" : "hinge") << "\" axis=\"" << vec(m_.axis[bu]) << "\"";
      const double lo = m_.q_lower[ju], hi = m_.q_upper[ju];
      if (c_.joint_limits && std::isfinite(lo) && std::isfinite(hi)) o << fmt::format(" limited=\"true\" range=\"{:.17g} {:.17g}\"", lo, hi);
      o << "/>\n";
    }
    const model::Inertia& I = m_.inertia[bu];
    const Matrix3d Ic = I.inertia_about_com();
    o << pad << fmt::format("  <inertial pos=\"{}\" mass=\"{:.17g}\" fullinertia=\"{:.17g} {:.17g} {:.17g} {:.17g} {:.17g} {:.17g}\"/>\n",
                            vec(I.com()), I.m, Ic(0, 0), Ic(1, 1), Ic(2, 2), Ic(0, 1), Ic(0, 2), Ic(1, 2));
    int n = 0;
    for (const CollisionShape& s : shapes_[bu]) {
      const std::string name = fmt::format("{}_collision_{}", xml_escape(m_.body_name[bu]), n++);
      o << pad << "  <geom name=\"" << name << "\" pos=\"" << vec(s.X_BG.p) << "\" quat=\"" << quat(s.X_BG.R) << "\"";
      switch (s.type) {
        case CollisionShape::Type::kBox: o << " type=\"box\" size=\"" << vec(s.size) << "\""; break;
        case CollisionShape::Type::kCylinder: o << fmt::format(" type=\"cylinder\" size=\"{:.17g} {:.17g}\"", s.size.x(), s.size.y()); break;
        case CollisionShape::Type::kSphere: o << fmt::format(" type=\"sphere\" size=\"{:.17g}\"", s.size.x()); break;
        case CollisionShape::Type::kHull: {
          assets_ << "    <mesh name=\"" << name << "\" vertex=\"";
          for (const Vector3d& p : s.points) assets_ << vec(p) << ' ';
          assets_ << "\"/>\n";
          o << " type=\"mesh\" mesh=\"" << name << "\"";
          break;
        }
      }
      o << "/>\n";
    }
    for (int c = b + 1; c < m_.nb; ++c) {
      if (m_.parent[static_cast<std::size_t>(c)] == b) write_body(c, o, indent + 1);
    }
    o << pad << "</body>\n";
  }

  const model::Model& m_;
  const SimConfig& c_;
  const std::vector<std::vector<CollisionShape>>& shapes_;
  std::ostringstream assets_;
};

class MujocoEngine final : public Engine {
 public:
  MujocoEngine(const model::Model& m, const SimConfig& config, const Shapes& shapes, const std::array<int, 2>& foot_body) : model_(&m) {
    xml_ = MjcfWriter(m, config, shapes).write();
    if (!config.mujoco.write_model.empty()) {
      // The model as MuJoCo gets it, for its own tools (simulate, compile).
      std::ofstream out(config.mujoco.write_model);
      out << xml_;
      if (!out) throw std::runtime_error("sim.mujoco.write_model: cannot write " + config.mujoco.write_model);
    }
    auto vfs = std::make_unique<mjVFS>();
    mj_defaultVFS(vfs.get());
    const char* file = "robot.xml";
    if (mj_makeEmptyFileVFS(vfs.get(), file, static_cast<int>(xml_.size())) != 0) throw std::runtime_error("MuJoCo: no room for the model");
    const int f = mj_findFileVFS(vfs.get(), file);
    std::memcpy(vfs->filedata[f], xml_.data(), xml_.size());
    char error[1000] = "";
    mj_ = mj_loadXML(file, vfs.get(), error, sizeof(error));
    mj_deleteVFS(vfs.get());
    if (mj_ == nullptr) throw model::ModelError(fmt::format("{}: MuJoCo does not load the simulated model: {}", m.source, error));
    d_ = mj_makeData(mj_);
    body_.resize(static_cast<std::size_t>(m.nb));
    for (int b = 0; b < m.nb; ++b) body_[static_cast<std::size_t>(b)] = mj_name2id(mj_, mjOBJ_BODY, m.body_name[static_cast<std::size_t>(b)].c_str());
    qadr_.resize(static_cast<std::size_t>(m.nj));
    dadr_.resize(static_cast<std::size_t>(m.nj));
    for (int j = 0; j < m.nj; ++j) {
      const int id = mj_name2id(mj_, mjOBJ_JOINT, m.joint_name[static_cast<std::size_t>(j)].c_str());
      qadr_[static_cast<std::size_t>(j)] = mj_->jnt_qposadr[id];
      dadr_[static_cast<std::size_t>(j)] = mj_->jnt_dofadr[id];
    }
    foot_of_body_.assign(static_cast<std::size_t>(mj_->nbody), -1);
    for (std::size_t k = 0; k < 2; ++k) foot_of_body_[static_cast<std::size_t>(body_[static_cast<std::size_t>(foot_body[k])])] = static_cast<int>(k);
    tau_ = Eigen::VectorXd::Zero(mj_->nv);
    damping_ = Eigen::VectorXd::Zero(mj_->nv);
  }
  ~MujocoEngine() override {
    mj_deleteData(d_);
    mj_deleteModel(mj_);
  }
  MujocoEngine(const MujocoEngine&) = delete;
  MujocoEngine& operator=(const MujocoEngine&) = delete;

  [[nodiscard]] const char* name() const override { return "mujoco"; }

  void set_state(const Eigen::VectorXd& q, const Eigen::VectorXd& v) override {
    // Free joint: position, orientation (w, x, y, z); linear velocity in the world, angular in the body.
    const Eigen::Quaterniond quat_WB(q(6), q(3), q(4), q(5));
    const Matrix3d R_WB = quat_WB.normalized().toRotationMatrix();
    for (int k = 0; k < 3; ++k) d_->qpos[k] = q(k);
    d_->qpos[3] = q(6);
    d_->qpos[4] = q(3);
    d_->qpos[5] = q(4);
    d_->qpos[6] = q(5);
    const Vector3d v_W = R_WB * v.head<3>();
    for (int k = 0; k < 3; ++k) {
      d_->qvel[k] = v_W(k);
      d_->qvel[3 + k] = v(3 + k);
    }
    for (int j = 0; j < model_->nj; ++j) {
      d_->qpos[qadr_[static_cast<std::size_t>(j)]] = q(7 + j);
      d_->qvel[dadr_[static_cast<std::size_t>(j)]] = v(6 + j);
    }
    mju_zero(d_->qacc_warmstart, mj_->nv);
    refresh();
  }
  void get_state(Eigen::VectorXd& q, Eigen::VectorXd& v) const override {
    q.resize(model_->nq);
    v.resize(model_->nv);
    for (int k = 0; k < 3; ++k) q(k) = d_->qpos[k];
    q(3) = d_->qpos[4];
    q(4) = d_->qpos[5];
    q(5) = d_->qpos[6];
    q(6) = d_->qpos[3];
    const Matrix3d R_WB = body_placement(0).R;
    v.head<3>() = R_WB.transpose() * Vector3d(d_->qvel[0], d_->qvel[1], d_->qvel[2]);
    v.segment<3>(3) = Vector3d(d_->qvel[3], d_->qvel[4], d_->qvel[5]);
    for (int j = 0; j < model_->nj; ++j) {
      q(7 + j) = d_->qpos[qadr_[static_cast<std::size_t>(j)]];
      v(6 + j) = d_->qvel[dadr_[static_cast<std::size_t>(j)]];
    }
  }
  [[nodiscard]] double joint_position(int j) const override { return d_->qpos[qadr_[static_cast<std::size_t>(j)]]; }
  [[nodiscard]] double joint_velocity(int j) const override { return d_->qvel[dadr_[static_cast<std::size_t>(j)]]; }
  void add_joint_torque(int j, double tau) override { tau_(dadr_[static_cast<std::size_t>(j)]) += tau; }
  // MuJoCo integrates joint damping implicitly (Euler: (M + h D) q̈ = τ − D q̇; the implicit
  // integrator too): a drive's
  // kd on a light foot against a soft contact stays stable where an explicit −kd q̇ would not
  // (the G1's feet, 0.6 kg on four 5 mm spheres, chattered off the ground at 3000 / 60).
  [[nodiscard]] bool integrates_damping() const override { return true; }
  void add_joint_damping(int j, double kd) override { damping_(dadr_[static_cast<std::size_t>(j)]) += kd; }
  void add_force(int b, const Vector3d& F_W, const Vector3d& p_W) override {
    const mjtNum torque[3] = {0.0, 0.0, 0.0};
    // mj_applyFT adds J(p)ᵀ (F, 0) to the target, with the Jacobian of the state at hand.
    mju_zero(d_->qfrc_applied, mj_->nv);
    mj_applyFT(mj_, d_, F_W.data(), torque, p_W.data(), body_[static_cast<std::size_t>(b)], d_->qfrc_applied);
    for (int i = 0; i < mj_->nv; ++i) tau_(i) += d_->qfrc_applied[i];
  }
  void step(double h, std::array<Vector6d, 2>& impulse_O) override {
    (void)h;  // the model's timestep (dt / substeps)
    for (int i = 0; i < mj_->nv; ++i) {
      d_->qfrc_applied[i] = tau_(i);
      mj_->dof_damping[i] = damping_(i);
    }
    tau_.setZero();
    damping_.setZero();
    mj_step(mj_, d_);
    // The contact forces of the step just taken (computed at its start): force on geom 2, along the
    // contact frame whose first row is the normal from geom 1 to geom 2.
    for (int i = 0; i < d_->ncon; ++i) {
      const mjContact& con = d_->contact[i];
      if (con.exclude != 0 || con.efc_address < 0) continue;
      const int b1 = mj_->geom_bodyid[con.geom1], b2 = mj_->geom_bodyid[con.geom2];
      const int k1 = foot_of_body_[static_cast<std::size_t>(b1)], k2 = foot_of_body_[static_cast<std::size_t>(b2)];
      if (k1 < 0 && k2 < 0) continue;
      mjtNum f[6];
      mj_contactForce(mj_, d_, i, f);
      Vector3d F = Vector3d::Zero(), tau = Vector3d::Zero();
      for (int r = 0; r < 3; ++r) {
        for (int a = 0; a < 3; ++a) {
          F(a) += con.frame[3 * r + a] * f[r];
          tau(a) += con.frame[3 * r + a] * f[3 + r];
        }
      }
      const Vector3d p(con.pos[0], con.pos[1], con.pos[2]);
      const Vector3d J = F * h, L = (p.cross(F) + tau) * h;
      if (k2 >= 0) {
        impulse_O[static_cast<std::size_t>(k2)].head<3>() += J;
        impulse_O[static_cast<std::size_t>(k2)].tail<3>() += L;
      }
      if (k1 >= 0) {
        impulse_O[static_cast<std::size_t>(k1)].head<3>() -= J;
        impulse_O[static_cast<std::size_t>(k1)].tail<3>() -= L;
      }
    }
    refresh();
  }
  [[nodiscard]] SE3 body_placement(int b) const override {
    const int id = body_[static_cast<std::size_t>(b)];
    SE3 X;
    X.p = Vector3d(d_->xpos + 3 * id);
    X.R = Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(d_->xmat + 9 * id);
    return X;
  }
  void body_motions(std::vector<BodyMotion>& out) const override {
    out.resize(static_cast<std::size_t>(model_->nb));
    for (int b = 0; b < model_->nb; ++b) {
      const int id = body_[static_cast<std::size_t>(b)];
      BodyMotion& o = out[static_cast<std::size_t>(b)];
      o.m = mj_->body_mass[id];
      o.I_principal = Vector3d(mj_->body_inertia + 3 * id);
      o.c_W = Vector3d(d_->xipos + 3 * id);
      o.R_WI = Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(d_->ximat + 9 * id);
      mjtNum vel[6];  // (ω, v) of the centre of mass, world orientation
      mj_objectVelocity(mj_, d_, mjOBJ_BODY, id, vel, 0);
      o.omega_W = Vector3d(vel[0], vel[1], vel[2]);
      o.v_W = Vector3d(vel[3], vel[4], vel[5]);
    }
  }

 private:
  /// The positions and velocities derived from the state just integrated (mj_step leaves those of
  /// the state before).
  void refresh() {
    mj_kinematics(mj_, d_);
    mj_comPos(mj_, d_);
    mj_comVel(mj_, d_);
  }

  const model::Model* model_;
  std::string xml_;
  mjModel* mj_ = nullptr;
  mjData* d_ = nullptr;
  std::vector<int> body_;          // MuJoCo body of each model body
  std::vector<int> qadr_, dadr_;   // qpos and qvel address of each model joint
  std::vector<int> foot_of_body_;  // per MuJoCo body: 0 / 1 for a foot, else -1
  Eigen::VectorXd tau_;            // generalized forces for the next step
  Eigen::VectorXd damping_;        // joint damping for the next step
};

}  // namespace

std::unique_ptr<Engine> make_mujoco_engine(const model::Model& m, const SimConfig& config, const Shapes& shapes,
                                           const std::array<int, 2>& foot_body) {
  return std::make_unique<MujocoEngine>(m, config, shapes, foot_body);
}

}  // namespace hpr::sim
