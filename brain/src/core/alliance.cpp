#include "pete/core/alliance.hpp"

#include <cmath>

namespace pete::core {

const char* to_string(AllianceSource s) {
  switch (s) {
    case AllianceSource::none:
      return "none";
    case AllianceSource::screen:
      return "the V5 screen";
    case AllianceSource::config:
      return "the configuration";
    case AllianceSource::gps:
      return "the GPS start pose";
  }
  return "?";
}

bool AllianceFinder::update(msg::Alliance screen, msg::MatchPeriod period, uint32_t enabled_ms,
                            bool gps_fix, double x_m) {
  msg::Alliance next = alliance_;
  AllianceSource from = source_;
  if (screen == msg::Alliance::red || screen == msg::Alliance::blue) {
    next = screen;
    from = AllianceSource::screen;
  } else if (fixed_ == msg::Alliance::red || fixed_ == msg::Alliance::blue) {
    next = fixed_;
    from = AllianceSource::config;
  } else {
    const bool waiting = period == msg::MatchPeriod::before || period == msg::MatchPeriod::after;
    const bool early = !waiting && enabled_ms < config_.lock_after_ms;
    if (source_ == AllianceSource::screen || source_ == AllianceSource::config) {
      // The pick was withdrawn: look again.
      next = msg::Alliance::unknown;
      from = AllianceSource::none;
    }
    if ((waiting || early) && gps_fix && std::isfinite(x_m)) {
      const double side = x_m * static_cast<double>(config_.red_side_x_sign);
      if (side > static_cast<double>(config_.center_margin_m)) {
        next = msg::Alliance::red;
        from = AllianceSource::gps;
      } else if (side < -static_cast<double>(config_.center_margin_m)) {
        next = msg::Alliance::blue;
        from = AllianceSource::gps;
      }
    }
  }
  const bool changed = next != alliance_ || from != source_;
  alliance_ = next;
  source_ = from;
  return changed;
}

}  // namespace pete::core
