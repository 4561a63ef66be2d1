// The step generator of the randomized whole-lab test: request sequences of three clients over a
// generated lab, predicted by the reference model as they are made.
#include <algorithm>
#include <cmath>

#include <motionlcm/request_t.hpp>
#include <motionlcm/sim_control_t.hpp>

#include "random_choice.hpp"
#include "random_lab.hpp"

namespace motion::random_lab {
namespace {

using motionlcm::request_t;

// A value for a move of `axis` in one of the interesting classes of distance.
double move_value(std::mt19937_64& rng, const AxisSpec& spec, const AxisModel& a, bool relative) {
  const double count = 1.0 / spec.steps_per_unit;
  const double sign = chance(rng, 0.5) ? 1.0 : -1.0;
  double target = a.commanded;
  switch (uniform_int(rng, 0, 9)) {
    case 0: target = a.commanded; break;                                          // exactly zero
    case 1: target = a.commanded + sign * 0.4 * count; break;                     // below one count
    case 2: target = a.commanded + sign * count; break;                           // one count
    case 3: target = a.commanded + sign * uniform_int(rng, 2, 9) * count; break;  // tiny
    case 4: target = chance(rng, 0.5) ? spec.min : spec.max; break;               // at a limit
    case 5:
      target = chance(rng, 0.5) ? spec.min - uniform(rng, 0.001, 5) : spec.max + uniform(rng, 0.001, 5);
      break;                                                                    // beyond
    default: target = round_to(uniform(rng, spec.min, spec.max), 0.01); break;  // ordinary
  }
  return relative ? target - a.commanded : target;
}

double scale(std::mt19937_64& rng) {
  switch (uniform_int(rng, 0, 9)) {
    case 0:
    case 1:
    case 2:
    case 3: return 0.0;
    case 4: return 1.0;
    case 5: return 0.05;
    default: return round_to(uniform(rng, 0.1, 1.0), 0.01);
  }
}

std::vector<std::string> some_axes(std::mt19937_64& rng, const LabSpec& lab, int max_count) {
  std::vector<std::string> names;
  for (const auto& a : lab.axes) names.push_back(a.name);
  std::shuffle(names.begin(), names.end(), rng);
  names.resize(static_cast<std::size_t>(uniform_int(rng, 1, std::min(max_count, static_cast<int>(names.size())))));
  return names;
}

// A move of up to three axes (to targets within their limits, a few seconds long) with a fault on
// one drive, or its bus, of the lab.
Step fault_step(std::mt19937_64& rng, const LabSpec& lab, const Model& model) {
  using motionlcm::sim_control_t;
  Step s;
  s.op = Op::kFault;
  s.client = uniform_int(rng, 0, 2);
  s.kind = request_t::MOVE_ABSOLUTE;
  s.axes = some_axes(rng, lab, 3);
  for (const auto& name : s.axes) {
    const auto& spec = *lab.find(name);
    s.values.push_back(round_to(uniform(rng, spec.min, spec.max), 0.01));
  }
  s.velocity_scale = std::min(1.0, round_to(std::max(0.05, scale_for(lab, model, s.axes, s.values, 3.0)) + 0.05, 0.01));
  s.second_axes = {
      chance(rng, 0.7)
          ? s.axes[static_cast<std::size_t>(uniform_int(rng, 0, static_cast<int>(s.axes.size()) - 1))]
          : lab.axes[static_cast<std::size_t>(uniform_int(rng, 0, static_cast<int>(lab.axes.size()) - 1))].name};
  const bool can = lab.find(s.second_axes[0])->drive.bus == "can0";
  std::vector<std::int8_t> faults{
      sim_control_t::STALL,         sim_control_t::SILENCE,
      sim_control_t::POWER_CYCLE,   sim_control_t::CRC_ERRORS,
      sim_control_t::REPLY_LATENCY, can ? sim_control_t::BUS_DROP : sim_control_t::LINE_NOISE};
  s.fault = pick(rng, faults);
  switch (s.fault) {
    case sim_control_t::SILENCE:
    case sim_control_t::CRC_ERRORS: s.fault_value = 1; break;
    case sim_control_t::REPLY_LATENCY: s.fault_value = pick(rng, std::vector<std::int32_t>{5000, 30000, 120000}); break;
    case sim_control_t::BUS_DROP: s.fault_value = uniform_int(rng, 1, 50); break;
    case sim_control_t::LINE_NOISE: s.fault_value = uniform_int(rng, 1, 16); break;
    default: break;
  }
  return s;
}

}  // namespace

// Slowest scale at which a move of `axes` to `targets` still ends within `seconds`.
double scale_for(const LabSpec& lab, const Model& model, const std::vector<std::string>& axes,
                 const std::vector<double>& targets, double seconds) {
  double need = 0;
  for (std::size_t i = 0; i < axes.size(); ++i) {
    const auto& spec = *lab.find(axes[i]);
    const auto& axis = model.axes().at(axes[i]);
    // Where an axis stands after a stopped jog or a fault is not known to the model: the farther
    // limit bounds the distance (a slow move from there outlasted its timeout: seed 7097).
    const double d = axis.at_target ? std::abs(targets[i] - axis.commanded)
                                    : std::max(std::abs(targets[i] - spec.min), std::abs(targets[i] - spec.max));
    need = std::max(need, d / (spec.velocity * seconds) + spec.velocity / (spec.acceleration * seconds));
  }
  return need;
}

std::vector<Step> generate_steps(std::mt19937_64& rng, const LabSpec& lab, int count, bool chaos) {
  Model model(lab);
  std::vector<Step> steps;
  std::vector<std::string> all;
  for (const auto& a : lab.axes) all.push_back(a.name);
  Step enable;
  enable.kind = request_t::ENABLE;
  enable.axes = all;
  enable.values.assign(all.size(), 0.0);
  steps.push_back(enable);
  model.request(request_t::ENABLE, all, steps.back().values, 0, 0, 0, true);
  while (static_cast<int>(steps.size()) < count) {
    Step s;
    s.client = uniform_int(rng, 0, 2);
    const int r = uniform_int(rng, 0, 99);
    bool any_disabled = false;
    for (const auto& [name, a] : model.axes()) any_disabled = any_disabled || !a.enabled;
    if (chaos && chance(rng, 0.2)) {
      steps.push_back(fault_step(rng, lab, model));
      // The recovery leaves every axis enabled at a position read back.
      for (const auto& a : lab.axes) {
        model.axis(a.name).enabled = true;
        model.axis(a.name).at_target = false;
      }
      continue;
    }
    if (any_disabled && r < 15) {
      s.kind = request_t::ENABLE;
      s.axes = all;
    } else if (r < 45) {
      s.kind = chance(rng, 0.55) ? request_t::MOVE_ABSOLUTE : request_t::MOVE_RELATIVE;
      s.axes = some_axes(rng, lab, 3);
      for (const auto& name : s.axes)
        s.values.push_back(move_value(rng, *lab.find(name), model.axes().at(name), s.kind == request_t::MOVE_RELATIVE));
      s.velocity_scale = scale(rng);
      s.acceleration_scale = scale(rng);
      std::vector<double> targets;
      for (std::size_t i = 0; i < s.axes.size(); ++i) {
        targets.push_back(s.kind == request_t::MOVE_RELATIVE ? model.axes().at(s.axes[i]).commanded + s.values[i]
                                                             : s.values[i]);
      }
      // At most ~6 s of motion per step.
      const double need = scale_for(lab, model, s.axes, targets, 6.0);
      if (s.velocity_scale != 0 && s.velocity_scale < need)
        s.velocity_scale = std::min(1.0, round_to(need + 0.05, 0.01));
      if (s.acceleration_scale != 0 && s.acceleration_scale < need)
        s.acceleration_scale = std::min(1.0, round_to(need + 0.05, 0.01));
      const int bad = uniform_int(rng, 0, 29);
      if (bad == 0) s.velocity_scale = pick(rng, std::vector<double>{-0.5, 1.5, 1.0000001});
      if (bad == 1) s.acceleration_scale = pick(rng, std::vector<double>{-0.01, 2.0});
      if (bad == 2) s.timeout_ms = -1;
    } else if (r < 52) {
      s.op = Op::kJogStop;
      s.kind = request_t::JOG;
      s.axes = some_axes(rng, lab, 2);
      for (const auto& name : s.axes) {
        const auto& spec = *lab.find(name);
        s.values.push_back(
            (chance(rng, 0.5) ? 1 : -1) *
            (chance(rng, 0.1) ? spec.velocity * 1.5 : round_to(spec.velocity * uniform(rng, 0.05, 0.3), 0.01)));
      }
      s.other_client = uniform_int(rng, 0, 2);
      s.stop_kind = chance(rng, 0.75) ? request_t::STOP : request_t::ESTOP;
    } else if (r < 62) {
      s.op = Op::kConflict;
      s.kind = request_t::MOVE_ABSOLUTE;
      s.axes = some_axes(rng, lab, 2);
      for (const auto& name : s.axes) {
        const auto& spec = *lab.find(name);
        const double at = model.axes().at(name).commanded;
        s.values.push_back(at - spec.min > spec.max - at ? spec.min : spec.max);  // the farther limit
      }
      // Slow enough to last ~10 s at the planned speed: far longer than the requests in between.
      s.velocity_scale = std::max(0.001, round_to(scale_for(lab, model, s.axes, s.values, 10.0) * 0.5, 0.001));
      // The drives' grids can stretch such a slow plan well past 10 s: a timeout that covers it
      // (the coordinator refuses a plan longer than the request's timeout).
      s.timeout_ms = 120000;
      s.other_client = (s.client + uniform_int(rng, 1, 2)) % 3;
      s.second_kind = pick(
          rng, std::vector<std::int8_t>{request_t::MOVE_ABSOLUTE, request_t::MOVE_RELATIVE, request_t::SET_POSITION,
                                        request_t::HOME, request_t::JOG, request_t::ENABLE});
      // Half of the time an axis of the running move, else any axes (maybe the free ones).
      s.second_axes = chance(rng, 0.5) ? std::vector<std::string>{s.axes[0]} : some_axes(rng, lab, 2);
      for (const auto& name : s.second_axes) {
        const auto& spec = *lab.find(name);
        if (s.second_kind == request_t::JOG)
          s.second_values.push_back(spec.velocity * 0.1);
        else if (s.second_kind == request_t::HOME || s.second_kind == request_t::ENABLE)
          s.second_values.push_back(0.0);
        else
          s.second_values.push_back(
              move_value(rng, spec, model.axes().at(name), s.second_kind == request_t::MOVE_RELATIVE));
      }
      // A jog of a free axis would run on: only moves end by themselves.
      if (s.second_kind == request_t::JOG) {
        for (const auto& name : s.second_axes) {
          if (std::find(s.axes.begin(), s.axes.end(), name) == s.axes.end()) s.second_kind = request_t::ENABLE;
        }
      }
      s.stop_kind = chance(rng, 0.8) ? request_t::STOP : request_t::ESTOP;
    } else if (r < 67) {
      s.kind = request_t::STOP;
      if (chance(rng, 0.6)) s.axes = some_axes(rng, lab, 3);
    } else if (r < 70) {
      s.kind = request_t::ESTOP;
      if (chance(rng, 0.5)) s.axes = some_axes(rng, lab, 3);
    } else if (r < 75) {
      s.kind = request_t::HOME;
      s.axes = some_axes(rng, lab, 2);
    } else if (r < 80) {
      s.kind = request_t::ENABLE;
      s.axes = some_axes(rng, lab, 3);
    } else if (r < 83) {
      s.kind = request_t::DISABLE;
      s.axes = some_axes(rng, lab, 2);
    } else if (r < 86) {
      s.kind = request_t::FAULT_RESET;
      s.axes = some_axes(rng, lab, 3);
    } else if (r < 93) {
      s.kind = request_t::SET_POSITION;
      s.axes = some_axes(rng, lab, 1);
      const auto& spec = *lab.find(s.axes[0]);
      const int c = uniform_int(rng, 0, 4);
      s.values.push_back(c == 0   ? spec.min
                         : c == 1 ? spec.max
                         : c == 2 ? spec.max + uniform(rng, 0.01, 10)
                                  : round_to(uniform(rng, spec.min, spec.max), 0.01));
    } else if (r < 96) {
      s.kind = request_t::SET_OUTPUTS;
      s.axes = some_axes(rng, lab, 1);
      s.output_mask = 1;
      s.output_value = uniform_int(rng, 0, 1);
    } else {
      s.kind = request_t::PARAM_READ;
      s.axes = some_axes(rng, lab, 1);
    }
    if (s.values.size() < s.axes.size()) s.values.resize(s.axes.size(), 0.0);
    // Advance the generator's model with the predicted outcome (positions after stops and jogs are
    // unknown to it; it keeps the last commanded target as a guess).
    if (s.op == Op::kRequest) {
      model.request(s.kind, s.axes, s.values, s.velocity_scale, s.acceleration_scale, s.timeout_ms, true);
    } else {
      model.request(s.stop_kind, s.axes, {}, 0, 0, 0, true);
      // Where the stop caught the slow move, and where the second request left its axes, is not
      // known here: the next moves' speeds must cover the whole travel (seed 9092: a move at 5 %
      // speed from there would have taken 21.6 s, beyond its 20 s timeout).
      for (const auto* names : {&s.axes, &s.second_axes}) {
        for (const auto& name : *names) model.axis(name).at_target = false;
      }
    }
    steps.push_back(std::move(s));
  }
  return steps;
}

}  // namespace motion::random_lab
