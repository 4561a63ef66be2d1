#include "motion/canopen/pdo_config.hpp"

#include <memory>

#include "motion/canopen/errors.hpp"
#include "motion/core/bytes.hpp"

namespace motion::canopen {
namespace {

std::uint64_t as_unsigned(std::span<const std::uint8_t> data) {
  std::uint64_t value = 0;
  for (std::size_t i = 0; i < data.size() && i < 8; ++i) value |= std::uint64_t{data[i]} << (8 * i);
  return value;
}

struct SequenceRun : std::enable_shared_from_this<SequenceRun> {
  SdoClient& client;
  NodeId node;
  std::vector<SdoStep> steps;
  SdoSequenceCallback done;
  std::size_t next = 0;

  SequenceRun(SdoClient& c, NodeId n, std::vector<SdoStep> s, SdoSequenceCallback d)
      : client(c), node(n), steps(std::move(s)), done(std::move(d)) {}

  void finish(std::error_code error) {
    if (done) done({error, error ? next : steps.size()});
  }

  void run_next() {
    if (next == steps.size()) return finish({});
    const SdoStep& step = steps[next];
    auto self = shared_from_this();
    if (step.action == SdoStep::Action::kWrite) {
      client.download(node, step.object, step.value,
                      [self](std::error_code error, std::span<const std::uint8_t>) { self->advance(error); });
      return;
    }
    client.upload(node, step.object, [self](std::error_code error, std::span<const std::uint8_t> data) {
      if (!error) {
        const SdoStep& verify = self->steps[self->next];
        if ((as_unsigned(data) & verify.compare_mask) != (as_unsigned(verify.value) & verify.compare_mask)) {
          error = CanopenError::kReadBackMismatch;
        }
      }
      self->advance(error);
    });
  }

  void advance(std::error_code error) {
    if (error) return finish(error);
    ++next;
    run_next();
  }
};

template <std::integral T>
SdoStep write_step(std::uint16_t index, std::uint8_t subindex, T value) {
  return {SdoStep::Action::kWrite, {index, subindex}, encode_value<T>(value), ~std::uint64_t{0}};
}

}  // namespace

void run_sdo_sequence(SdoClient& client, NodeId node, std::vector<SdoStep> steps, SdoSequenceCallback done) {
  std::make_shared<SequenceRun>(client, node, std::move(steps), std::move(done))->run_next();
}

std::optional<std::vector<SdoStep>> pdo_remap_steps(const PdoConfiguration& config, bool verify) {
  if (config.number < 1 || config.number > kMaxPdoNumber || !pdo_payload_size(config.mapping) ||
      config.mapping.size() > 0xFE) {
    return std::nullopt;
  }
  const std::uint16_t comm = pdo_communication_index(config.direction, config.number);
  const std::uint16_t map = pdo_mapping_index(config.direction, config.number);
  const std::uint32_t enabled_cob_id = config.cob_id & ~kPdoCobIdInvalid;
  const auto count = static_cast<std::uint8_t>(config.mapping.size());

  std::vector<SdoStep> steps;
  steps.push_back(write_step<std::uint32_t>(comm, kPdoCobIdSub, enabled_cob_id | kPdoCobIdInvalid));
  steps.push_back(write_step<std::uint8_t>(map, 0, 0));
  for (std::uint8_t i = 0; i < count; ++i) {
    steps.push_back(
        write_step<std::uint32_t>(map, static_cast<std::uint8_t>(i + 1), encode_mapping_entry(config.mapping[i])));
  }
  steps.push_back(write_step<std::uint8_t>(map, 0, count));
  if (config.transmission_type) steps.push_back(write_step(comm, kPdoTransmissionTypeSub, *config.transmission_type));
  if (config.inhibit_time) steps.push_back(write_step(comm, kPdoInhibitTimeSub, *config.inhibit_time));
  if (config.event_timer) steps.push_back(write_step(comm, kPdoEventTimerSub, *config.event_timer));
  steps.push_back(write_step<std::uint32_t>(comm, kPdoCobIdSub, enabled_cob_id));
  if (!verify) return steps;

  // Read back the final value of every object written. Steps 0 and 1 (disabled COB-ID, count 0)
  // were overwritten by later steps.
  const std::size_t write_count = steps.size();
  for (std::size_t i = 2; i < write_count; ++i) {
    SdoStep check = steps[i];
    check.action = SdoStep::Action::kVerify;
    if (check.object == ObjectAddress{comm, kPdoCobIdSub}) check.compare_mask = ~std::uint64_t{kPdoCobIdNoRtr};
    steps.push_back(std::move(check));
  }
  return steps;
}

void configure_pdo(SdoClient& client, NodeId node, const PdoConfiguration& config, SdoSequenceCallback done,
                   bool verify) {
  auto steps = pdo_remap_steps(config, verify);
  if (!steps) {
    if (done) done({CanopenError::kInvalidArgument, 0});
    return;
  }
  run_sdo_sequence(client, node, std::move(*steps), std::move(done));
}

}  // namespace motion::canopen
