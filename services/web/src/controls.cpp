#include "motion/web/controls.hpp"

#include <sys/random.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <set>

#include <nlohmann/json.hpp>

#include "motion/lcm/request_kinds.hpp"

namespace motion::web {
namespace {

using motionlcm::request_t;

// The kinds the page may send, by their constant names.
constexpr std::array kPageKinds{request_t::ENABLE,        request_t::DISABLE, request_t::MOVE_ABSOLUTE,
                                request_t::MOVE_RELATIVE, request_t::JOG,     request_t::STOP,
                                request_t::ESTOP,         request_t::HOME,    request_t::FAULT_RESET};

bool takes_values(std::int8_t kind) {
  return kind == request_t::MOVE_ABSOLUTE || kind == request_t::MOVE_RELATIVE || kind == request_t::JOG;
}
bool may_name_no_axis(std::int8_t kind) { return kind == request_t::STOP || kind == request_t::ESTOP; }

// Equal length and bytes, in time that does not depend on where they differ.
bool same_token(std::string_view given, std::string_view token) {
  if (given.size() != token.size() || token.empty()) return false;
  unsigned char diff = 0;
  for (std::size_t i = 0; i < token.size(); ++i) diff = static_cast<unsigned char>(diff | (given[i] ^ token[i]));
  return diff == 0;
}

std::string page_kind_names() {
  std::string names;
  for (const auto kind : kPageKinds) names += (names.empty() ? "" : ", ") + std::string(lcm::request_kind_name(kind));
  return names;
}

}  // namespace

std::variant<ControlRequest, ControlError> parse_control(std::string_view text, const config::Config& config,
                                                         std::string_view token) {
  const auto json = nlohmann::json::parse(text, nullptr, false);
  if (json.is_discarded() || !json.is_object()) return ControlError{std::nullopt, "a command is one JSON object"};
  std::optional<std::int64_t> tag;
  if (const auto t = json.find("tag"); t != json.end() && t->is_number_integer()) tag = t->get<std::int64_t>();
  auto refuse = [&](std::string why) { return ControlError{tag, std::move(why)}; };

  if (const auto type = json.find("type"); type == json.end() || *type != "command")
    return refuse("\"type\" must be \"command\"");
  if (!tag) return refuse("\"tag\" must be an integer");
  const auto given = json.find("token");
  if (given == json.end() || !given->is_string() || !same_token(given->get_ref<const std::string&>(), token)) {
    return refuse(
        "wrong or missing access token: open the page at the address motion-web printed (\"controls at "
        "...?token=...\")");
  }

  const auto kind_field = json.find("kind");
  if (kind_field == json.end() || !kind_field->is_string())
    return refuse("\"kind\" must be one of " + page_kind_names());
  const auto& kind_name = kind_field->get_ref<const std::string&>();
  const auto kind = std::find_if(kPageKinds.begin(), kPageKinds.end(),
                                 [&](std::int8_t k) { return kind_name == lcm::request_kind_name(k); });
  if (kind == kPageKinds.end())
    return refuse("kind '" + kind_name + "' is not one the page may send (" + page_kind_names() + ")");

  ControlRequest out;
  out.tag = *tag;
  auto& r = out.request;
  r.kind = *kind;

  const auto axes = json.find("axes");
  if (axes == json.end() || !axes->is_array()) return refuse("\"axes\" must be an array of axis names");
  std::set<std::string> seen;
  for (const auto& a : *axes) {
    if (!a.is_string()) return refuse("\"axes\" must be an array of axis names");
    const auto& name = a.get_ref<const std::string&>();
    if (config.find_axis(name) == nullptr) return refuse("no axis '" + name + "' in " + config.file);
    if (!seen.insert(name).second) return refuse("axis '" + name + "' named twice");
    r.axes.push_back(name);
  }
  if (r.axes.empty() && !may_name_no_axis(r.kind))
    return refuse(std::string(lcm::request_kind_name(r.kind)) + " needs at least one axis");

  const auto values = json.find("values");
  if (takes_values(r.kind)) {
    if (values == json.end() || !values->is_array() || values->size() != r.axes.size()) {
      return refuse("\"values\" must hold one number per axis for " + std::string(lcm::request_kind_name(r.kind)));
    }
    for (const auto& v : *values) {
      if (!v.is_number() || !std::isfinite(v.get<double>())) return refuse("\"values\" must be finite numbers");
      r.values.push_back(v.get<double>());
    }
  } else {
    if (values != json.end() && !(values->is_array() && values->empty())) {
      return refuse(std::string(lcm::request_kind_name(r.kind)) + " takes no values");
    }
    r.values.assign(r.axes.size(), 0.0);
  }
  for (const auto& [field, target] :
       {std::pair{"velocity_scale", &r.velocity_scale}, std::pair{"acceleration_scale", &r.acceleration_scale}}) {
    const auto f = json.find(field);
    if (f == json.end() || f->is_null()) continue;
    if (!f->is_number() || !(f->get<double>() > 0.0 && f->get<double>() <= 1.0)) {
      return refuse("\"" + std::string(field) + "\" must be in (0, 1]");
    }
    *target = f->get<double>();
  }
  r.num_axes = static_cast<std::int32_t>(r.axes.size());
  return out;
}

std::string control_accepted(std::int64_t tag, std::string_view request_id) {
  return nlohmann::json{{"type", "command_result"}, {"tag", tag}, {"ok", true}, {"id", request_id}}.dump();
}

std::string control_refused(const ControlError& error) {
  nlohmann::json out{{"type", "command_result"}, {"ok", false}, {"error", error.error}};
  out["tag"] = error.tag ? nlohmann::json(*error.tag) : nlohmann::json(nullptr);
  return out.dump();
}

std::string new_access_token() {
  std::array<unsigned char, 16> bytes{};
  if (::getrandom(bytes.data(), bytes.size(), 0) != static_cast<ssize_t>(bytes.size())) return {};
  static constexpr char kHex[] = "0123456789abcdef";
  std::string token;
  for (const auto b : bytes) {
    token += kHex[b >> 4];
    token += kHex[b & 0x0f];
  }
  return token;
}

}  // namespace motion::web
