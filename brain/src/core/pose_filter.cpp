#include "pete/core/pose_filter.hpp"

#include <cmath>

namespace pete::core {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDegToRad = kPi / 180.0;
constexpr double kRadToDeg = 180.0 / kPi;
// An IMU rotation step larger than this (a sensor reset, a glitch) is not believed.
constexpr double kMaxImuStepRad = 1.0;
// The wheels' turn may differ from the IMU's by this fraction of the turn before it is slip (a
// skid-steer drive's effective track is not its geometric one; the twin's 24-inch robot has a
// wider track than kRobotConfig's).
constexpr double kTurnTolerance = 0.75;

double wrap(double a) {
  a = std::fmod(a, 2.0 * kPi);
  if (a > kPi) a -= 2.0 * kPi;
  if (a <= -kPi) a += 2.0 * kPi;
  return a;
}

bool finite(double v) { return std::isfinite(v); }

/// Inverse of a symmetric 3x3 matrix; false when it is (numerically) singular.
bool invert3(const double (&m)[3][3], double (&out)[3][3]) {
  const double c00 = m[1][1] * m[2][2] - m[1][2] * m[2][1];
  const double c01 = m[1][2] * m[2][0] - m[1][0] * m[2][2];
  const double c02 = m[1][0] * m[2][1] - m[1][1] * m[2][0];
  const double det = m[0][0] * c00 + m[0][1] * c01 + m[0][2] * c02;
  if (!(std::fabs(det) > 1e-300) || !finite(det)) return false;
  const double inv = 1.0 / det;
  out[0][0] = c00 * inv;
  out[0][1] = (m[0][2] * m[2][1] - m[0][1] * m[2][2]) * inv;
  out[0][2] = (m[0][1] * m[1][2] - m[0][2] * m[1][1]) * inv;
  out[1][0] = c01 * inv;
  out[1][1] = (m[0][0] * m[2][2] - m[0][2] * m[2][0]) * inv;
  out[1][2] = (m[0][2] * m[1][0] - m[0][0] * m[1][2]) * inv;
  out[2][0] = c02 * inv;
  out[2][1] = (m[0][1] * m[2][0] - m[0][0] * m[2][1]) * inv;
  out[2][2] = (m[0][0] * m[1][1] - m[0][1] * m[1][0]) * inv;
  return true;
}

}  // namespace

const char* to_string(GpsUpdate u) {
  switch (u) {
    case GpsUpdate::none:
      return "none";
    case GpsUpdate::initialised:
      return "pose initialised from the GPS";
    case GpsUpdate::accepted:
      return "accepted";
    case GpsUpdate::rejected:
      return "gps reading rejected: a jump";
    case GpsUpdate::reanchored:
      return "pose re-anchored to the GPS";
  }
  return "?";
}

void PoseFilter::reset() {
  initialised_ = false;
  ever_fixed_ = false;
  rejecting_ = false;
  hist_count_ = 0;
  hist_head_ = 0;
}

void PoseFilter::start(double x_m, double y_m, double heading_rad, double std_m) {
  initialised_ = true;
  x_ = x_m;
  y_ = y_m;
  h_ = wrap(heading_rad);
  const double hs = config_.gps_heading_std_deg * kDegToRad;
  for (auto& row : p_) {
    for (double& v : row) v = 0.0;
  }
  p_[0][0] = p_[1][1] = std_m * std_m;
  p_[2][2] = hs * hs;
  hist_count_ = 0;
  hist_head_ = 0;
  remember();
  rejecting_ = false;
  push_var_ = 0.0;
}

void PoseFilter::remember() {
  hist_[hist_head_][0] = x_;
  hist_[hist_head_][1] = y_;
  hist_[hist_head_][2] = h_;
  hist_head_ = (hist_head_ + 1) % kHistory;
  if (hist_count_ < kHistory) ++hist_count_;
}

void PoseFilter::commanded(double left_mps, double right_mps) {
  cmd_known_ = finite(left_mps) && finite(right_mps);
  if (cmd_known_) {
    cmd_left_ = left_mps;
    cmd_right_ = right_mps;
  }
}

void PoseFilter::predict(double dt_s, double left_mps, double right_mps, bool imu_ok,
                         double imu_deg, double track_width_m) {
  const bool imu_good = imu_ok && finite(imu_deg);
  const bool use_imu = imu_good && imu_known_;
  const double imu_step = use_imu ? (imu_deg - imu_last_deg_) * kDegToRad : 0.0;
  imu_known_ = imu_good;
  if (imu_good) imu_last_deg_ = imu_deg;
  if (!initialised_ || !(dt_s > 0.0) || !finite(dt_s) || !(track_width_m > 0.0)) return;
  step_s_ = dt_s;

  const double l = finite(left_mps) ? left_mps : 0.0;
  const double r = finite(right_mps) ? right_mps : 0.0;
  const double d = 0.5 * (l + r) * dt_s;
  const double wheel_turn = (l - r) / track_width_m * dt_s;  // clockwise
  const bool imu_used = use_imu && std::fabs(imu_step) <= kMaxImuStepRad;
  const double dh = imu_used ? imu_step : wheel_turn;

  // Slip: how far the wheels' measured speeds are from what the motors were told, and the
  // wheels' turn from the IMU's (as a wheel surface speed), beyond what normal driving gives.
  double disagree = 0.0;
  if (cmd_known_) {
    disagree = std::fmax(std::fabs(cmd_left_ - l), std::fabs(cmd_right_ - r));
    cmd_known_ = false;  // one command per step
  }
  if (imu_used) {
    // A skid-steer drive's effective track differs from the geometric one (scrub), so the
    // wheels' turn may be off the IMU's by kTurnTolerance of the turn before it counts.
    const double half_track = 0.5 * track_width_m / dt_s;
    const double turn_mps = std::fabs(wheel_turn - imu_step) * half_track -
                            kTurnTolerance * std::fabs(imu_step) * half_track;
    disagree = std::fmax(disagree, turn_mps);
  }
  const double slip = disagree > config_.slip_deadband_mps
                          ? (disagree - config_.slip_deadband_mps) * dt_s
                          : 0.0;
  slip_m_ += slip;
  const double hm = h_ + 0.5 * dh;
  const double s = std::sin(hm);
  const double c = std::cos(hm);
  x_ += d * s;
  y_ += d * c;
  h_ = wrap(h_ + dh);

  // P = F P F^T + Q, F = [[1, 0, d c], [0, 1, -d s], [0, 0, 1]].
  const double f02 = d * c;
  const double f12 = -d * s;
  double fp[3][3];
  for (int j = 0; j < 3; ++j) {
    fp[0][j] = p_[0][j] + f02 * p_[2][j];
    fp[1][j] = p_[1][j] + f12 * p_[2][j];
    fp[2][j] = p_[2][j];
  }
  double n[3][3];
  for (int i = 0; i < 3; ++i) {
    n[i][0] = fp[i][0] + fp[i][2] * f02;
    n[i][1] = fp[i][1] + fp[i][2] * f12;
    n[i][2] = fp[i][2];
  }
  // Slip: mostly along the direction driven, some sideways; plus a little with time.
  const double q = config_.odom_var_per_m * std::fabs(d);
  const double qt = config_.pos_var_per_s * dt_s + config_.slip_var_per_m * slip;
  n[0][0] += q * s * s + 0.25 * q + qt;
  n[1][1] += q * c * c + 0.25 * q + qt;
  n[0][1] += q * s * c;
  n[1][0] += q * s * c;
  n[2][2] += imu_used ? config_.heading_var_per_rad_imu * std::fabs(dh) +
                            config_.heading_var_per_s_imu * dt_s
                      : config_.heading_var_per_rad_wheels * std::fabs(dh) +
                            config_.heading_var_per_m_wheels * std::fabs(d);
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) p_[i][j] = 0.5 * (n[i][j] + n[j][i]);
  }
  remember();
}

GpsUpdate PoseFilter::correct(double x_m, double y_m, double heading_deg, double error_m,
                              uint32_t now_ms) {
  if (!finite(x_m) || !finite(y_m) || !finite(heading_deg) || !finite(error_m) ||
      error_m < 0.0 || error_m > config_.gps_max_error_m) {
    return GpsUpdate::none;
  }
  const double sigma = error_m > config_.gps_min_std_m ? error_m : config_.gps_min_std_m;
  const double hz = wrap(heading_deg * kDegToRad);
  if (!initialised_) {
    start(x_m, y_m, hz, sigma);
    ever_fixed_ = true;
    last_fix_ms_ = now_ms;
    ++accepted_;
    return GpsUpdate::initialised;
  }

  // The filter's pose when the sensor saw the strip.
  const double lag_steps = static_cast<double>(config_.gps_latency_ms) / 1000.0 / step_s_;
  std::size_t lag = lag_steps > 0.0 ? static_cast<std::size_t>(lag_steps + 0.5) : 0;
  if (lag + 1 > hist_count_) lag = hist_count_ > 0 ? hist_count_ - 1 : 0;
  const std::size_t newest = (hist_head_ + kHistory - 1) % kHistory;
  const std::size_t at = (newest + kHistory - lag) % kHistory;
  const double rx = hist_count_ > 0 ? hist_[at][0] : x_;
  const double ry = hist_count_ > 0 ? hist_[at][1] : y_;
  const double rh = hist_count_ > 0 ? hist_[at][2] : h_;
  const double innov[3] = {x_m - rx, y_m - ry, wrap(hz - rh)};

  const double hs = config_.gps_heading_std_deg * kDegToRad;
  double sm[3][3];
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) sm[i][j] = p_[i][j];
  }
  sm[0][0] += sigma * sigma;
  sm[1][1] += sigma * sigma;
  sm[2][2] += hs * hs;
  double si[3][3];
  if (!invert3(sm, si)) return GpsUpdate::none;
  double m2 = 0.0;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) m2 += innov[i] * si[i][j] * innov[j];
  }
  if (!(m2 <= config_.gate_chi2)) {
    ++rejected_;
    if (!rejecting_) {
      rejecting_ = true;
      rejecting_since_ms_ = now_ms;
      push_var_ = 0.0;
    }
    const uint32_t for_ms = now_ms - rejecting_since_ms_;
    if (for_ms >= config_.reanchor_ms) {
      start(x_m, y_m, hz, sigma);
      ++reanchors_;
      last_fix_ms_ = now_ms;
      return GpsUpdate::reanchored;
    }
    // The robot may be moving without its wheels saying so: widen the position's uncertainty
    // to what push_mps covers in the time the GPS has not been believed: since the last accepted
    // reading (after a dropout the robot may have been pushed all through it, unseen), or since
    // the rejections began.
    const uint32_t unseen_ms =
        ever_fixed_ && now_ms - last_fix_ms_ > for_ms ? now_ms - last_fix_ms_ : for_ms;
    double spread = config_.push_mps * static_cast<double>(unseen_ms) / 1000.0;
    if (spread > 0.5 * config_.lost_std_m) spread = 0.5 * config_.lost_std_m;  // never lost by it
    const double add = spread * spread - push_var_;
    if (add > 0.0) {
      p_[0][0] += add;
      p_[1][1] += add;
      push_var_ += add;
    }
    return GpsUpdate::rejected;
  }
  rejecting_ = false;

  // K = P S^-1; state += K innov; P = (I - K) P.
  double k[3][3];
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) {
      k[i][j] = p_[i][0] * si[0][j] + p_[i][1] * si[1][j] + p_[i][2] * si[2][j];
    }
  }
  double dx[3];
  for (int i = 0; i < 3; ++i) dx[i] = k[i][0] * innov[0] + k[i][1] * innov[1] + k[i][2] * innov[2];
  x_ += dx[0];
  y_ += dx[1];
  h_ = wrap(h_ + dx[2]);
  double n[3][3];
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) {
      const double ikp = p_[i][j] - (k[i][0] * p_[0][j] + k[i][1] * p_[1][j] + k[i][2] * p_[2][j]);
      n[i][j] = ikp;
    }
  }
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) p_[i][j] = 0.5 * (n[i][j] + n[j][i]);
  }
  // The poses remembered for the next late reading move with the correction.
  for (std::size_t i = 0; i < hist_count_; ++i) {
    hist_[i][0] += dx[0];
    hist_[i][1] += dx[1];
    hist_[i][2] = wrap(hist_[i][2] + dx[2]);
  }
  ever_fixed_ = true;
  last_fix_ms_ = now_ms;
  ++accepted_;
  return GpsUpdate::accepted;
}

double PoseFilter::heading_deg() const {
  double h = h_ * kRadToDeg;
  if (h < 0.0) h += 360.0;
  if (h >= 360.0) h -= 360.0;
  return h;
}

double PoseFilter::position_std_m() const {
  const double a = p_[0][0];
  const double d = p_[1][1];
  const double b = p_[0][1];
  const double half = 0.5 * (a - d);
  const double lmax = 0.5 * (a + d) + std::sqrt(half * half + b * b);
  return lmax > 0.0 ? std::sqrt(lmax) : 0.0;
}

double PoseFilter::heading_std_deg() const {
  return p_[2][2] > 0.0 ? std::sqrt(p_[2][2]) * kRadToDeg : 0.0;
}

msg::PoseFix PoseFilter::fix(uint32_t now_ms) const {
  if (!initialised_ || !(position_std_m() <= config_.lost_std_m)) return msg::PoseFix::lost;
  if (ever_fixed_ && now_ms - last_fix_ms_ <= config_.gps_fix_hold_ms) return msg::PoseFix::gps;
  return msg::PoseFix::odometry;
}

}  // namespace pete::core
