// Gateway (gateway.hpp): what both command types go through (the plain channels under enforce,
// the command memory), and gateway_command2_t, whose motion values are integers of the drive
// models' grids. Checked against the model this gateway published for each axis and turned into
// the stacks' command exactly (grid_command.hpp); from there on it is a command like any other:
// the same checks, ledger, replies and command memory (a repeat is answered, never run again).
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <motionlcm/event_t.hpp>

#include "motion/gateway/command_ledger.hpp"
#include "motion/gateway/gateway.hpp"
#include "motion/gateway/grid_command.hpp"
#include "motion/lcm/channels.hpp"

namespace motion::gateway {

template <typename Command>
void Gateway::on_plain(const Command& command, void (Gateway::*handler)(const Command&)) {
  if (enforce_) {
    return refuse("unsigned command " + std::to_string(command.command_id) + " (request " +
                  std::to_string(command.request_id) +
                  ") refused: security is enforced, commands must be signed by the coordinator");
  }
  (this->*handler)(command);
}

template void Gateway::on_plain(const motionlcm::gateway_command_t&,
                                void (Gateway::*)(const motionlcm::gateway_command_t&));
template void Gateway::on_plain(const motionlcm::gateway_command2_t&,
                                void (Gateway::*)(const motionlcm::gateway_command2_t&));

template <typename Command>
bool Gateway::answered_again(const Command& command) {
  std::optional<motionlcm::gateway_reply_t> latest;
  if (!commands_seen_.repeated(command, &latest)) return false;
  spdlog::info("command {} (request {}) sent again: {}", command.command_id, command.request_id,
               latest ? "its latest reply repeated" : "not answered yet");
  ++(latest ? repeats_answered_ : repeats_unanswered_);
  if (latest) publish_own(lcm::channels::kGatewayReply, *latest, false);
  return true;
}

template bool Gateway::answered_again(const motionlcm::gateway_command_t&);
template bool Gateway::answered_again(const motionlcm::gateway_command2_t&);

void Gateway::on_command2(const motionlcm::gateway_command2_t& command) {
  if (answered_again(command)) return;
  auto converted = from_grid(command, [this](const std::string& axis) -> const motionlcm::drive_model_t* {
    const auto it = models_.find(axis);
    return it == models_.end() ? nullptr : &it->second;
  });
  if (auto* refusal = std::get_if<GridRefusal>(&converted)) {
    refusal_event({}, command.command_id, command.request_id, refusal->error_code, refusal->reason);
    return command_reply(ReplyBuilder(command.command_id).failed(refusal->error_code, refusal->reason).build());
  }
  execute_checked(std::get<motionlcm::gateway_command_t>(converted));
}

bool Gateway::same_model(motionlcm::drive_model_t a, motionlcm::drive_model_t b) {
  a.utime = 0;
  b.utime = 0;
  std::vector<std::uint8_t> x(static_cast<std::size_t>(a.getEncodedSize()));
  std::vector<std::uint8_t> y(static_cast<std::size_t>(b.getEncodedSize()));
  a.encode(x.data(), 0, static_cast<int>(x.size()));
  b.encode(y.data(), 0, static_cast<int>(y.size()));
  return x == y;
}

}  // namespace motion::gateway
