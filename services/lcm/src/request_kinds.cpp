#include "motion/lcm/request_kinds.hpp"

#include <array>

#include <motionlcm/request_t.hpp>

namespace motion::lcm {
namespace {

using motionlcm::request_t;

struct KindNames {
  std::int8_t kind;
  const char* name;
  const char* words;
};

constexpr std::array<KindNames, 13> kKinds{{
    {request_t::MOVE_ABSOLUTE, "MOVE_ABSOLUTE", "move"},
    {request_t::MOVE_RELATIVE, "MOVE_RELATIVE", "relative move"},
    {request_t::JOG, "JOG", "jog"},
    {request_t::STOP, "STOP", "stop"},
    {request_t::ESTOP, "ESTOP", "e-stop"},
    {request_t::HOME, "HOME", "home"},
    {request_t::ENABLE, "ENABLE", "enable"},
    {request_t::DISABLE, "DISABLE", "disable"},
    {request_t::FAULT_RESET, "FAULT_RESET", "fault reset"},
    {request_t::SET_OUTPUTS, "SET_OUTPUTS", "set outputs"},
    {request_t::PARAM_READ, "PARAM_READ", "parameter read"},
    {request_t::PARAM_WRITE, "PARAM_WRITE", "parameter write"},
    {request_t::SET_POSITION, "SET_POSITION", "set position"},
}};

const KindNames* find(std::int8_t kind) {
  for (const auto& k : kKinds) {
    if (k.kind == kind) return &k;
  }
  return nullptr;
}

}  // namespace

const char* request_kind_name(std::int8_t kind) {
  const auto* k = find(kind);
  return k != nullptr ? k->name : "UNKNOWN";
}

const char* request_kind_words(std::int8_t kind) {
  const auto* k = find(kind);
  return k != nullptr ? k->words : "unknown";
}

bool request_kind_moves(std::int8_t kind) {
  return kind == request_t::MOVE_ABSOLUTE || kind == request_t::MOVE_RELATIVE || kind == request_t::JOG ||
         kind == request_t::HOME;
}

std::string request_label(const request_t& request) {
  return std::string(request_kind_words(request.kind)) + " request " + std::to_string(request.request_id) +
         " of client '" + request.client_id + "'";
}

}  // namespace motion::lcm
