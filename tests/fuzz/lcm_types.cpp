// Every LCM type a process receives (table-driven over the types of lcmtypes/*.lcm): the first
// byte selects the type, the rest is the message as it would arrive on its channel.
#include <stdexcept>

#include "fuzz_targets.hpp"
#include "motion/lcm/wire_bounds.hpp"

namespace motion::fuzz {

int lcm_types(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  const auto& types = lcm::wire::all_types();
  const auto& type = types[data[0] % types.size()];
  // As Node::subscribe decodes: bounded check first, then lcm-gen's decode.
  (void)type.decode(data + 1, size - 1);
  return 0;
}

int lcm_types_unchecked(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  const auto& types = lcm::wire::all_types();
  const auto& type = types[data[0] % types.size()];
  try {
    (void)type.decode_unchecked(data + 1, size - 1);
  } catch (const std::length_error&) {
    // lcm-gen's string decode of a zero length; the allocation before it is what matters.
  }
  return 0;
}

}  // namespace motion::fuzz
