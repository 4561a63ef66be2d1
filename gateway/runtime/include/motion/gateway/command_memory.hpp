// What a gateway remembers of the commands it got: a command that arrives again word for word is
// the coordinator sending it again because no reply to it was heard (LCM may lose the command or
// its reply; the coordinator re-sends every kCommandResend until it hears one). Such a repeat must
// not run again (an ARM_MOVE armed twice, an ENABLE sent to the drives twice); its latest reply,
// if any yet, goes out again instead.
//
// Commands are told apart by their whole encoding (the coordinator re-sends the same bytes, its
// send time included), so a restarted coordinator's command ids, which start again at 1, are new
// commands; a gateway_command_t and a gateway_command2_t never match (the encoding begins with the
// type's fingerprint). The last kRemembered commands are kept.
//
// Passive; thread contract: one thread (the gateway's loop).
#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>
#include <map>
#include <optional>

#include <motionlcm/gateway_command2_t.hpp>
#include <motionlcm/gateway_command_t.hpp>
#include <motionlcm/gateway_reply_t.hpp>

namespace motion::gateway {

class CommandMemory {
 public:
  static constexpr std::size_t kRemembered = 1024;

  // True when `command` arrived before; then `*latest` is its latest reply (nullopt: none yet).
  // Otherwise it is remembered from now on and false is returned.
  bool repeated(const motionlcm::gateway_command_t& command, std::optional<motionlcm::gateway_reply_t>* latest);
  bool repeated(const motionlcm::gateway_command2_t& command, std::optional<motionlcm::gateway_reply_t>* latest);
  // A reply to a remembered command (by id: the latest command of that id).
  void replied(const motionlcm::gateway_reply_t& reply);

 private:
  bool repeated(std::uint64_t digest, std::int64_t command_id, std::optional<motionlcm::gateway_reply_t>* latest);
  struct Seen {
    std::int64_t command_id = 0;
    std::optional<motionlcm::gateway_reply_t> reply;
  };
  std::map<std::uint64_t, Seen> seen_;           // by digest of the encoding
  std::map<std::int64_t, std::uint64_t> by_id_;  // command id -> digest
  std::deque<std::uint64_t> order_;              // oldest first
};

}  // namespace motion::gateway
