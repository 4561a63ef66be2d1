#include "motion/gateway/command_memory.hpp"

#include <vector>

namespace motion::gateway {
namespace {

// FNV-1a, 64 bits, of the command's LCM encoding (with its fingerprint).
template <typename Command>
std::uint64_t digest(const Command& command) {
  std::vector<std::uint8_t> bytes(static_cast<std::size_t>(command.getEncodedSize()));
  command.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
  std::uint64_t h = 14695981039346656037ULL;
  for (const auto b : bytes) {
    h ^= b;
    h *= 1099511628211ULL;
  }
  return h;
}

}  // namespace

bool CommandMemory::repeated(const motionlcm::gateway_command_t& command,
                             std::optional<motionlcm::gateway_reply_t>* latest) {
  return repeated(digest(command), command.command_id, latest);
}

bool CommandMemory::repeated(const motionlcm::gateway_command2_t& command,
                             std::optional<motionlcm::gateway_reply_t>* latest) {
  return repeated(digest(command), command.command_id, latest);
}

bool CommandMemory::repeated(std::uint64_t key, std::int64_t command_id,
                             std::optional<motionlcm::gateway_reply_t>* latest) {
  if (const auto it = seen_.find(key); it != seen_.end() && it->second.command_id == command_id) {
    *latest = it->second.reply;
    return true;
  }
  seen_[key] = Seen{command_id, std::nullopt};
  by_id_[command_id] = key;
  order_.push_back(key);
  while (order_.size() > kRemembered) {
    const auto old = seen_.find(order_.front());
    if (old != seen_.end()) {
      if (const auto id = by_id_.find(old->second.command_id); id != by_id_.end() && id->second == old->first)
        by_id_.erase(id);
      seen_.erase(old);
    }
    order_.pop_front();
  }
  return false;
}

void CommandMemory::replied(const motionlcm::gateway_reply_t& reply) {
  const auto id = by_id_.find(reply.command_id);
  if (id == by_id_.end()) return;
  if (const auto it = seen_.find(id->second); it != seen_.end()) it->second.reply = reply;
}

}  // namespace motion::gateway
