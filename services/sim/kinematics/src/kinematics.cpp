#include "motion/sim/kinematics.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace motion::sim {
namespace {

constexpr double kForever = std::numeric_limits<double>::infinity();

double seconds(Duration d) { return std::chrono::duration<double>(d).count(); }
TimePoint after(TimePoint t, double s) {
  return t + std::chrono::duration_cast<Duration>(std::chrono::duration<double>(s));
}
double sign(double x) { return x > 0 ? 1.0 : (x < 0 ? -1.0 : 0.0); }

}  // namespace

Kinematics::State Kinematics::at(TimePoint now) const {
  for (const auto& s : segments_) {
    const double t = std::max(0.0, seconds(now - s.start));
    if (t <= s.duration) return {s.x0 + s.v0 * t + 0.5 * s.a * t * t, s.v0 + s.a * t, true};
  }
  return {rest_position_, 0.0, false};
}

std::int64_t Kinematics::position_counts(TimePoint now) const { return std::llround(at(now).position); }

TimePoint Kinematics::end_time() const {
  if (segments_.empty() || std::isinf(segments_.back().duration)) return kNever;
  return after(segments_.back().start, segments_.back().duration);
}

void Kinematics::push(TimePoint& t, double& x, double& v, double a, double duration) {
  if (!(duration > 0)) return;
  segments_.push_back({t, x, v, a, duration});
  if (std::isinf(duration)) return;
  x += v * duration + 0.5 * a * duration * duration;
  v += a * duration;
  t = after(t, duration);
}

void Kinematics::ramp_to(TimePoint& t, double& x, double& v, double v_target, double rate) {
  if (rate <= 0 || v == v_target) {
    v = v_target;
    return;
  }
  const double duration = std::abs(v_target - v) / rate;
  push(t, x, v, sign(v_target - v) * rate, duration);
  v = v_target;  // exact, despite rounding in push
}

void Kinematics::plan_ptp(TimePoint now, State from, double target, const Profile& p) {
  segments_.clear();
  TimePoint t = now;
  double x = from.position;
  double v = from.velocity;
  const double a = std::max(p.acceleration, 1e-9);
  const double d = std::max(p.deceleration, 1e-9);
  const double vmax = std::max(std::abs(p.velocity), 1e-9);
  const double end_speed = std::min(p.cut_in, vmax);

  double dir = sign(target - x);
  // Moving away from the target, or too fast to stop before it: come to rest first.
  const double stop_distance = std::abs(v) > end_speed ? (v * v - end_speed * end_speed) / (2 * d) : 0.0;
  if (v * dir < 0 || (v != 0 && stop_distance > std::abs(target - x))) {
    ramp_to(t, x, v, sign(v) * std::min(std::abs(v), end_speed), d);
    v = 0;
    dir = sign(target - x);
  }
  const double distance = std::abs(target - x);
  if (distance > 0) {
    double u = std::abs(v);
    if (u == 0) u = std::min(p.cut_in, vmax);  // cut-in jump from rest
    if (u > vmax) {                            // slower set speed while moving: decelerate to it
      ramp_to(t, x, v, dir * vmax, d);
      u = vmax;
    }
    const double remaining = std::abs(target - x);
    const double peak_sq = (2 * a * d * remaining + d * u * u + a * end_speed * end_speed) / (a + d);
    v = dir * u;
    if (u == 0 && peak_sq <= 0) {
      // nothing: distance is zero after the ramp
    } else if (peak_sq >= vmax * vmax) {
      const double accel_distance = (vmax * vmax - u * u) / (2 * a);
      const double decel_distance = (vmax * vmax - end_speed * end_speed) / (2 * d);
      ramp_to(t, x, v, dir * vmax, a);
      push(t, x, v, 0, std::max(0.0, remaining - accel_distance - decel_distance) / vmax);
      ramp_to(t, x, v, dir * end_speed, d);
    } else if (peak_sq >= u * u) {
      const double peak = std::sqrt(peak_sq);
      ramp_to(t, x, v, dir * peak, a);
      ramp_to(t, x, v, dir * end_speed, d);
      if (end_speed == 0 && segments_.empty() && u > 0) push(t, x, v, 0, remaining / u);
    } else {
      // Too little room to decelerate at `d` from the current speed: brake harder, as the drive
      // would overshoot otherwise.
      const double rate = (u * u - end_speed * end_speed) / (2 * remaining);
      ramp_to(t, x, v, dir * end_speed, rate);
    }
    if (end_speed > 0 && segments_.empty()) push(t, x, v, 0, remaining / end_speed);
  }
  rest_position_ = target;
  jogging_ = false;
}

void Kinematics::move_to(TimePoint now, std::int64_t target, const Profile& profile) {
  plan_ptp(now, at(now), static_cast<double>(target), profile);
  exact_target_ = target;
  has_exact_target_ = true;
}

void Kinematics::jog(TimePoint now, const Profile& profile) {
  const State s = at(now);
  segments_.clear();
  TimePoint t = now;
  double x = s.position;
  double v = s.velocity;
  const double target = profile.velocity;
  if (v * target < 0) ramp_to(t, x, v, 0, profile.deceleration);
  if (target == 0) {
    stop(now, profile.deceleration, profile.cut_in);
    return;
  }
  if (v == 0) v = sign(target) * std::min(profile.cut_in, std::abs(target));  // cut-in jump
  ramp_to(t, x, v, target, std::abs(target) > std::abs(v) ? profile.acceleration : profile.deceleration);
  push(t, x, v, 0, kForever);
  jogging_ = true;
  has_exact_target_ = false;
}

void Kinematics::stop(TimePoint now, double deceleration, double cut_in) {
  const State s = at(now);
  segments_.clear();
  TimePoint t = now;
  double x = s.position;
  double v = s.velocity;
  if (s.moving) ramp_to(t, x, v, sign(v) * std::min(std::abs(v), cut_in), deceleration);
  rest_position_ = std::round(x);
  jogging_ = false;
  has_exact_target_ = false;
}

void Kinematics::halt(TimePoint now) {
  const State s = at(now);
  segments_.clear();
  rest_position_ = std::round(s.position);
  jogging_ = false;
  has_exact_target_ = false;
}

void Kinematics::set_position(TimePoint /*now*/, std::int64_t position) {
  segments_.clear();
  rest_position_ = static_cast<double>(position);
  jogging_ = false;
  has_exact_target_ = false;
}

}  // namespace motion::sim
