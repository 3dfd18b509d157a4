// The robot's pose from the GPS, the wheel odometry and the V5 inertial sensor: a small extended
// Kalman filter over (x, y, heading) in the GPS's field frame (metres; heading in degrees
// clockwise from the field's +y, [0, 360)).
//
//   predict  every loop step, from the wheels' measured surface speeds (distance driven) and the
//            IMU's rotation since the last step (the heading change; the wheels' difference when
//            the IMU is absent or calibrating). Uncertainty grows with the distance driven, the
//            angle turned and, with the IMU, slowly with time (its drift). Slip: where the
//            wheels' measured speeds are off what the motors were told (commanded(): pushing a
//            goal, a robot or a wall; being pushed), or the wheels' turn is off the IMU's by more
//            than three quarters of the turn (a wheel spinning; a skid-steer's effective track
//            is not its geometric one), by more than slip_deadband_mps, the robot may be moving
//            in ways the wheels do not see: the position's uncertainty grows by slip_var_per_m
//            per metre of that disagreement.
//   correct  with each GPS reading the sensor calls ok, weighted by the sensor's own RMS error
//            (never below gps_min_std_m). The reading is compared with the filter's pose of
//            gps_latency_ms ago, when the sensor saw the strip, and the correction applied to
//            the pose now. A reading too far from the pose for its uncertainty (a chi-square gate
//            on all three numbers) is rejected as a jump. While readings keep being rejected, the
//            position's uncertainty grows at push_mps (a robot pushed sideways moves without its
//            wheels turning), counted from the last accepted reading and up to half of
//            lost_std_m: the first readings after a dropout the robot may have been pushed all
//            through are believed within a reading or two, a GPS that stays put is believed again
//            within a fraction of a second, and a short glitch is not; after reanchor_ms of
//            rejections the filter starts again from the GPS, and says so.
//
// The pose's trust: position_std_m() is the standard deviation along the position's worst axis,
// heading_std_deg() the heading's; fix() says what the pose rests on (lost: nothing yet, or the
// uncertainty grew past lost_std_m; gps: a reading was accepted within gps_fix_hold_ms;
// odometry: odometry and the IMU since the last accepted reading).
//
// No heap, no exceptions; bad numbers (NaN, infinities) in any input are ignored, never stored.
#pragma once

#include <cstddef>
#include <cstdint>

#include "pete/messages.hpp"

namespace pete::core {

struct PoseFilterConfig {
  double gps_min_std_m;             // floor on a GPS reading's position std (VEX: about 13 mm)
  double gps_heading_std_deg;       // a GPS reading's heading std
  double gps_max_error_m;           // readings whose own RMS error is larger are not used
  uint32_t gps_latency_ms;          // how old a GPS reading is when the Brain reads it
  double odom_var_per_m;            // m^2 of position variance per metre driven (wheel slip)
  double pos_var_per_s;             // m^2 of position variance per second, moving or not
  double heading_var_per_rad_imu;   // rad^2 of heading variance per radian turned, with the IMU
  double heading_var_per_s_imu;     // rad^2 per second: the IMU's drift
  double heading_var_per_rad_wheels;  // rad^2 per radian turned, from the wheels alone
  double heading_var_per_m_wheels;    // rad^2 per metre driven, from the wheels alone
  double gate_chi2;                 // chi-square gate on a reading's innovation (3 degrees of freedom)
  double push_mps;                  // while readings are rejected, the pose may be moving unseen
                                    //   (pushed sideways): its std grows this fast
  uint32_t reanchor_ms;             // readings rejected this long in a row: start from the GPS
  uint32_t gps_fix_hold_ms;         // fix() says gps this long after an accepted reading
  double lost_std_m;                // position std beyond this: fix() says lost
  double slip_deadband_mps;         // wheel-speed disagreement (told vs measured, wheels vs IMU)
                                    //   up to this is normal driving (motor response, noise)
  double slip_var_per_m;            // m^2 of position variance per metre of disagreement beyond
                                    //   the deadband (motion the wheels may not have seen)
};

/// What one GPS correction did.
enum class GpsUpdate : uint8_t { none, initialised, accepted, rejected, reanchored };

const char* to_string(GpsUpdate u);

class PoseFilter {
 public:
  static constexpr std::size_t kHistory = 16;  // loop steps of past poses, for the GPS latency

  explicit PoseFilter(const PoseFilterConfig& config) : config_(config) {}

  /// One loop step of dead reckoning: `dt_s` since the last step, the wheels' measured surface
  /// speeds (m/s), the IMU's cumulative clockwise rotation (degrees) when `imu_ok`, and the track
  /// width (m) for turning from the wheels when the IMU cannot be used.
  void predict(double dt_s, double left_mps, double right_mps, bool imu_ok, double imu_deg,
               double track_width_m);
  /// The wheel surface speeds (m/s) the motors were told this step (0, 0 when stopped), for the
  /// next predict() to compare with the measured ones. Not called: no such comparison.
  void commanded(double left_mps, double right_mps);
  /// Correct with a GPS reading (field frame, metres, degrees clockwise; its own RMS error).
  GpsUpdate correct(double x_m, double y_m, double heading_deg, double error_m, uint32_t now_ms);
  /// Forget everything (the next good GPS reading starts the filter again).
  void reset();

  bool initialised() const { return initialised_; }
  double x() const { return x_; }
  double y() const { return y_; }
  /// Heading in degrees, [0, 360).
  double heading_deg() const;
  double position_std_m() const;
  double heading_std_deg() const;
  msg::PoseFix fix(uint32_t now_ms) const;

  uint32_t accepted() const { return accepted_; }
  uint32_t rejected() const { return rejected_; }
  uint32_t reanchors() const { return reanchors_; }
  /// Metres of wheel-speed disagreement beyond the deadband since start (how much slip it saw).
  double slip_m() const { return slip_m_; }

 private:
  void start(double x_m, double y_m, double heading_rad, double std_m);
  void remember();

  PoseFilterConfig config_;
  bool initialised_ = false;
  double x_ = 0.0, y_ = 0.0, h_ = 0.0;  // h_ in radians, clockwise, kept in (-pi, pi]
  double p_[3][3] = {};                  // covariance of (x, y, h)

  bool cmd_known_ = false;
  double cmd_left_ = 0.0, cmd_right_ = 0.0;
  double slip_m_ = 0.0;

  bool imu_known_ = false;
  double imu_last_deg_ = 0.0;

  // The poses of the last kHistory steps, newest last, for comparing a late GPS reading.
  double hist_[kHistory][3] = {};
  std::size_t hist_count_ = 0;
  std::size_t hist_head_ = 0;
  double step_s_ = 0.01;  // the last step's length, to turn the latency into steps

  bool ever_fixed_ = false;
  uint32_t last_fix_ms_ = 0;
  bool rejecting_ = false;
  uint32_t rejecting_since_ms_ = 0;
  double push_var_ = 0.0;  // position variance added for unseen motion during the rejections
  uint32_t accepted_ = 0;
  uint32_t rejected_ = 0;
  uint32_t reanchors_ = 0;
};

}  // namespace pete::core
