#include "hpr/sim/multibody.hpp"

#include <Eigen/Eigenvalues>

#include "hpr/model/algorithms.hpp"

namespace hpr::sim {

using model::SE3;
using Eigen::Matrix3d;
using Eigen::Vector3d;

btQuaternion to_bt_quaternion(const Matrix3d& R) {
  const Eigen::Quaterniond q(R);
  return {q.x(), q.y(), q.z(), q.w()};
}

Matrix3d from_bt(const btQuaternion& q) {
  return Eigen::Quaterniond(q.w(), q.x(), q.y(), q.z()).normalized().toRotationMatrix();
}

namespace {
BulletBody principal_frame(const model::Inertia& I) {
  BulletBody b;
  const Eigen::SelfAdjointEigenSolver<Matrix3d> es(I.inertia_about_com());
  Matrix3d R = es.eigenvectors();
  if (R.determinant() < 0) R.col(2) = -R.col(2);
  b.X_BL.R = R;
  b.X_BL.p = I.com();
  b.inertia = es.eigenvalues();
  return b;
}
}  // namespace

MultiBodyRobot::MultiBodyRobot(const model::Model& model) : model_(&model) {
  for (int i = 0; i < model.nb; ++i) bodies_.push_back(principal_frame(model.inertia[static_cast<size_t>(i)]));
  const BulletBody& base = bodies_[0];
  mb_ = std::make_unique<btMultiBody>(model.nb - 1, model.inertia[0].m, to_bt(base.inertia), false, false);
  for (int i = 1; i < model.nb; ++i) {
    const auto iu = static_cast<size_t>(i);
    const int p = model.parent[iu];
    const BulletBody& bi = bodies_[iu];
    const BulletBody& bp = bodies_[static_cast<size_t>(p)];
    const SE3& X_PJ = model.X_PJ[iu];
    // Rotation taking vectors in the parent link frame to this link frame at q = 0.
    const Matrix3d R_this_parent = bi.X_BL.R.transpose() * X_PJ.R.transpose() * bp.X_BL.R;
    const Vector3d axis = bi.X_BL.R.transpose() * model.axis[iu];
    const Vector3d parent_com_to_pivot = bp.X_BL.R.transpose() * (X_PJ.p - bp.X_BL.p);
    const Vector3d pivot_to_com = bi.X_BL.R.transpose() * bi.X_BL.p;
    if (model.kind[iu] == model::JointKind::kRevolute) {
      mb_->setupRevolute(i - 1, model.inertia[iu].m, to_bt(bi.inertia), p - 1, to_bt_quaternion(R_this_parent),
                         to_bt(axis), to_bt(parent_com_to_pivot), to_bt(pivot_to_com), true);
    } else {
      mb_->setupPrismatic(i - 1, model.inertia[iu].m, to_bt(bi.inertia), p - 1, to_bt_quaternion(R_this_parent),
                          to_bt(axis), to_bt(parent_com_to_pivot), to_bt(pivot_to_com), true);
    }
  }
  mb_->finalizeMultiDof();
  mb_->setLinearDamping(0.0);
  mb_->setAngularDamping(0.0);
  mb_->setUseGyroTerm(true);
  mb_->setCanSleep(false);
  mb_->setHasSelfCollision(false);
  mb_->setMaxCoordinateVelocity(1e3);
}

MultiBodyRobot::~MultiBodyRobot() {
  if (!owned_) (void)mb_.release();
}

btMultiBody* MultiBodyRobot::release() {
  owned_ = false;
  return mb_.get();
}

void MultiBodyRobot::set_state(const Eigen::VectorXd& q, const Eigen::VectorXd& v) {
  const Matrix3d R_WB = model::base_quaternion(q).toRotationMatrix();
  const Vector3d p_WB = q.head<3>();
  const BulletBody& b0 = bodies_[0];
  btTransform tr;
  tr.setOrigin(to_bt(p_WB + R_WB * b0.X_BL.p));
  tr.setRotation(to_bt_quaternion(R_WB * b0.X_BL.R));
  mb_->setBaseWorldTransform(tr);
  const Vector3d wB = v.segment<3>(3);
  mb_->setBaseOmega(to_bt(R_WB * wB));
  mb_->setBaseVel(to_bt(R_WB * (v.head<3>() + wB.cross(b0.X_BL.p))));
  for (int j = 0; j < model_->nj; ++j) {
    mb_->setJointPos(j, q(7 + j));
    mb_->setJointVel(j, v(6 + j));
  }
  btAlignedObjectArray<btQuaternion> world_to_local;
  btAlignedObjectArray<btVector3> local_origin;
  mb_->forwardKinematics(world_to_local, local_origin);
}

void MultiBodyRobot::get_state(Eigen::VectorXd& q, Eigen::VectorXd& v) const {
  q.resize(model_->nq);
  v.resize(model_->nv);
  const BulletBody& b0 = bodies_[0];
  const Matrix3d R_WL = from_bt(mb_->getWorldToBaseRot().inverse());
  const Matrix3d R_WB = R_WL * b0.X_BL.R.transpose();
  const Vector3d p_WB = from_bt(mb_->getBasePos()) - R_WB * b0.X_BL.p;
  q.head<3>() = p_WB;
  const Eigen::Quaterniond quat(R_WB);
  q(3) = quat.x();
  q(4) = quat.y();
  q(5) = quat.z();
  q(6) = quat.w();
  const Vector3d wB = R_WB.transpose() * from_bt(mb_->getBaseOmega());
  v.segment<3>(3) = wB;
  v.head<3>() = R_WB.transpose() * from_bt(mb_->getBaseVel()) - wB.cross(b0.X_BL.p);
  for (int j = 0; j < model_->nj; ++j) {
    q(7 + j) = mb_->getJointPos(j);
    v(6 + j) = mb_->getJointVel(j);
  }
}

void MultiBodyRobot::add_generalized_force(const Eigen::VectorXd& tau) {
  const Matrix3d R_WL = from_bt(mb_->getWorldToBaseRot().inverse());
  const Matrix3d R_WB = R_WL * bodies_[0].X_BL.R.transpose();
  const Vector3d f_B = tau.head<3>();
  const Vector3d t_B = tau.segment<3>(3) - bodies_[0].X_BL.p.cross(f_B);
  mb_->addBaseForce(to_bt(R_WB * f_B));
  mb_->addBaseTorque(to_bt(R_WB * t_B));
  for (int j = 0; j < model_->nj; ++j) mb_->addJointTorque(j, tau(6 + j));
}

Eigen::VectorXd MultiBodyRobot::to_model_acceleration(const Eigen::VectorXd& acc, const Eigen::VectorXd& v) const {
  const Matrix3d R_WL = from_bt(mb_->getWorldToBaseRot().inverse());
  const Matrix3d R_WB = R_WL * bodies_[0].X_BL.R.transpose();
  const Vector3d c0 = bodies_[0].X_BL.p;
  Eigen::VectorXd a(model_->nv);
  const Vector3d wB = v.segment<3>(3);
  const Vector3d wdB = R_WB.transpose() * acc.head<3>();
  a.segment<3>(3) = wdB;
  a.head<3>() = R_WB.transpose() * acc.segment<3>(3) - wB.cross(v.head<3>() + wB.cross(c0)) - wdB.cross(c0);
  a.tail(model_->nj) = acc.tail(model_->nj);
  return a;
}

SE3 MultiBodyRobot::link_frame(int body) const {
  SE3 X_WL;
  if (body == 0) {
    X_WL.R = from_bt(mb_->getWorldToBaseRot().inverse());
    X_WL.p = from_bt(mb_->getBasePos());
  } else {
    const btTransform& t = mb_->getLink(body - 1).m_cachedWorldTransform;
    X_WL.R = from_bt(t.getRotation());
    X_WL.p = from_bt(t.getOrigin());
  }
  return X_WL;
}

SE3 MultiBodyRobot::body_placement(int body) const {
  return link_frame(body) * bodies_[static_cast<size_t>(body)].X_BL.inverse();
}

}  // namespace hpr::sim
