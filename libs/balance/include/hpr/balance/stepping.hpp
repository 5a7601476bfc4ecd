#pragma once
/// \file
/// Stepping, the third balance strategy: when the ankle and the hip strategies together cannot hold
/// the robot, take a step. Everything here is the linear inverted pendulum (LIP) of the CoM at a
/// constant height z_c above flat ground, in the horizontal plane of the world frame:
///
///   c̈ = ω² (c − p),   ω = √(g / z_c),                                   (LIP)
///   ξ = c + ċ / ω          the divergent component of motion (DCM), or instantaneous capture point,
///   ξ̇ = ω (ξ − p)          so with p held:  ξ(t) = p + (ξ(0) − p) e^{ωt}.     (DCM)
///
/// p is the centroidal moment pivot (CMP): the CoP shifted by the centroidal moment the hip strategy
/// applies, p = p_CoP − (τ_y, −τ_x) / (m g) for a CAM rate l̇_c = τ. The ankle strategy moves the CoP
/// within the support polygon; the hip strategy (the paper's CAM reference, bounded by its torque
/// and by the joint limits) moves the CMP beyond it for a while. When ξ lies outside the support
/// polygon grown by what the hip strategy can add, no CoP inside the polygon and no CAM within its
/// bounds can stop the divergence: the robot must step. What the hip strategy can add shrinks as
/// the trunk leans into ξ (SteppingConfig::lean_range): the range it turns through is spent.
///
/// The step (Englsberger's DCM step adjustment): with the CMP held at the stance foot's p_st during a
/// swing of duration T, the DCM at touchdown is ξ_T = p_st + (ξ_0 − p_st) e^{ωT}. Landing the swing
/// sole at u = ξ_T − b leaves the DCM at offset b from the new sole, inside the new support, from
/// where the ankle and hip strategies of the paper bring the robot to rest. The planner searches T
/// within [T_min, T_max] and u within a reachability box around the stance foot, away from it (and on
/// the ground the configuration declares, if it does), for
/// the pair closest to the nominal step that keeps ξ_T − u nearest to b; replanned each tick.

#include <Eigen/Core>
#include <array>
#include <optional>

#include "hpr/common/config.hpp"

namespace hpr::balance {

/// The LIP's natural frequency ω = √(g / z_c) [1/s] for a CoM height z_c [m] above the ground.
double lip_omega(double z_c, double g = 9.81);

/// The instantaneous capture point ξ = c + ċ/ω (horizontal components) [m].
Eigen::Vector2d capture_point(const Eigen::Vector2d& c, const Eigen::Vector2d& cd, double omega);

/// ξ after `t` seconds with the CMP held at `p` (the DCM closed form).
Eigen::Vector2d dcm_after(const Eigen::Vector2d& xi0, const Eigen::Vector2d& p, double omega, double t);

/// The capture point's shift [m] by an external horizontal force `f` [N] on a mass `m` [kg] that
/// lasts `t_remaining` more seconds: F / (m ω²) (1 − e^{−ω t_remaining}). With the CMP held at p the
/// pendulum c̈ = ω² (c − p) + F / m comes to rest over p after the force ends iff ξ + shift = p; a
/// force that lasts for good shifts ξ by F / (m ω²), the CMP that holds it.
Eigen::Vector2d push_shift(const Eigen::Vector2d& f, double m, double omega, double t_remaining);

/// A sole on flat ground: its centre, yaw and half sizes (the support rectangle).
struct Sole {
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();
  double yaw = 0.0;
  double half_length = 0.0, half_width = 0.0;
  /// `x` (world) in the sole frame.
  [[nodiscard]] Eigen::Vector2d to_local(const Eigen::Vector2d& x) const;
  [[nodiscard]] Eigen::Vector2d to_world(const Eigen::Vector2d& local) const;
};

/// Signed distance [m] from `x` to the convex hull of the soles in contact (one or two rectangles):
/// negative inside (minus the distance to the nearest edge), positive outside.
double support_distance(const std::array<Sole, 2>& soles, const std::array<bool, 2>& contact, const Eigen::Vector2d& x);

/// The point of the support (the convex hull of the soles in contact, each shrunk by `inset` on
/// every side) nearest to `x`: x itself inside, else its projection on the hull's boundary. The
/// CMP that comes closest to a wanted one while the CoP stays `inset` inside the soles.
Eigen::Vector2d support_point(const std::array<Sole, 2>& soles, const std::array<bool, 2>& contact, const Eigen::Vector2d& x,
                              double inset = 0.0);

/// The CMP a stance sole can hold nearest to the capture point `xi`: ξ clamped into the sole (the
/// ankle strategy at the edge the robot falls over).
Eigen::Vector2d stance_cmp(const Sole& stance, const Eigen::Vector2d& xi);

struct SteppingConfig {
  bool enabled = false;        ///< take steps (else the ankle and hip strategies only, as the paper)
  double margin = 0.0;         ///< [m] ξ may come this close to the grown support edge before a step
  double cmp_reach = 0.025;    ///< [m] how far beyond the support the hip strategy holds the capture point
                               ///<     (shifted by the push, push_shift) without a step, ahead and to the sides
  /// [m] the same behind the support (a push from the front), where the hip strategy may hold more:
  /// the trunk leans back to gain it, with more range than leaning forward, where stretched knees end
  /// it early. Between the directions the reach blends with the squares of the direction's components.
  double cmp_reach_backward = 0.025;
  /// [m] the same beside the support (a push from the side), where the hip strategy turns the trunk
  /// about x and its reach is the robot's own (a wide stance holds more standing than a step gives).
  /// It blends in with the eighth power of the sideways component (1/16 of it at 45°), so that the
  /// diagonals keep nearly the forward or backward reach: a sole loaded at its corner tilts sooner
  /// than one loaded along its edge.
  double cmp_reach_sideways = 0.025;
  /// [rad] what is left of the reach shrinks with the base's lean towards ξ, to nothing at this
  /// lean: the hip strategy holds ξ beyond the support by turning the trunk through its range (the
  /// flywheel of the capture-point literature), and a trunk already leaning into ξ has less of that
  /// range left. 0: the reach holds whatever the lean.
  double lean_range = 0.0;
  double t_min = 0.25, t_max = 0.6, t_nominal = 0.35;  ///< [s] swing duration bounds and nominal
  double dcm_offset = 0.0;     ///< [m] b: ξ_T − u wanted along the push, >0 lands short of the DCM
  /// Reachability of the swing sole centre in the stance sole's frame (x forward, y towards the
  /// swing side) [m]: forward/backward, and lateral from min_width (clear of the stance foot) to
  /// max_width.
  double reach_forward = 0.35, reach_backward = 0.25, min_width = 0.16, max_width = 0.45;
  /// The flat ground a step may land on, in the world frame [m]: {x_min, x_max, y_min, y_max}, the
  /// whole landed sole inside. Unbounded when not configured. A step with no landing both in the
  /// reachability box and on this ground is not taken (the ankle and hip strategies do what they can).
  std::optional<std::array<double, 4>> ground;
  double weight_position = 1.0;  ///< cost of the step's distance from the nominal landing (u = ξ_T − b)
  double weight_offset = 10.0;   ///< cost of ξ_T − u missing b (the DCM left outside the new sole)
  double weight_time = 0.1;      ///< [1/s²] cost of T's distance from t_nominal
  int time_samples = 16;         ///< durations searched in [t_min, t_max]
  static SteppingConfig load(const Config& stepping_section);
};

/// A planned step.
struct StepPlan {
  int swing = -1;                       ///< model::kRight or model::kLeft
  Eigen::Vector2d target = Eigen::Vector2d::Zero();  ///< landing position of the swing sole centre (world)
  double yaw = 0.0;                     ///< landing yaw (the stance foot's)
  double duration = 0.0;                ///< T [s] from now to touchdown
  Eigen::Vector2d xi_touchdown = Eigen::Vector2d::Zero();  ///< ξ_T predicted with the CMP at the stance sole
  bool reachable = true;                ///< the unconstrained landing lay inside the reachability box
  bool placeable = true;                ///< some landing in the box keeps the sole on the declared ground
  double cost = 0.0;
};

/// The decision and the step planner (allocation-free; one per controller).
class StepPlanner {
 public:
  explicit StepPlanner(SteppingConfig config) : config_(config) {}

  /// How far ξ lies beyond the support polygon grown by the hip strategy's CMP reach (positive: a
  /// step is needed; the margin already counted), for soles `soles` with `contact`. `lean` is the
  /// horizontal part of the base's z axis in the world (sin of its tilt, in the tilt's direction);
  /// its component towards ξ takes its share of lean_range off the reach.
  [[nodiscard]] double excess(const std::array<Sole, 2>& soles, const std::array<bool, 2>& contact,
                              const Eigen::Vector2d& xi, const Eigen::Vector2d& lean = Eigen::Vector2d::Zero()) const;
  /// Whether a step is needed now (stepping enabled and excess() > 0).
  [[nodiscard]] bool step_needed(const std::array<Sole, 2>& soles, const std::array<bool, 2>& contact,
                                 const Eigen::Vector2d& xi, const Eigen::Vector2d& lean = Eigen::Vector2d::Zero()) const;
  /// The foot to swing: the one on the side the DCM runs to when it runs sideways (the push's
  /// lateral component), else the one carrying less of the weight (`load` fractions, summing to 1).
  [[nodiscard]] int choose_swing(const std::array<Sole, 2>& soles, const Eigen::Vector2d& xi,
                                 const std::array<double, 2>& load) const;
  /// The step of `swing` with the other sole as stance, from DCM ξ_0 `xi`, for the LIP frequency
  /// `omega`; `elapsed` of the swing already done (replanning: T ≥ t_min − elapsed, and the
  /// remaining time is searched).
  [[nodiscard]] StepPlan plan(const std::array<Sole, 2>& soles, int swing, const Eigen::Vector2d& xi, double omega,
                              double elapsed = 0.0) const;
  /// The landing of `swing` for a touchdown exactly `remaining` seconds from now (the replanning
  /// during a swing whose timing is kept).
  [[nodiscard]] StepPlan plan_landing(const std::array<Sole, 2>& soles, int swing, const Eigen::Vector2d& xi, double omega,
                                      double remaining) const;

  [[nodiscard]] const SteppingConfig& config() const { return config_; }

 private:
  /// The step of `swing` landing after T: its landing and cost.
  [[nodiscard]] StepPlan evaluate(const std::array<Sole, 2>& soles, int swing, const Eigen::Vector2d& xi, double omega,
                                  double T, double t_nominal) const;

  SteppingConfig config_;
};

}  // namespace hpr::balance
