#include "motion/canopen/sdo_client.hpp"

#include <algorithm>
#include <limits>
#include <utility>

#include "frame_util.hpp"
#include "motion/canopen/cob_id.hpp"
#include "motion/canopen/errors.hpp"

namespace motion::canopen {
namespace {

constexpr auto code(SdoAbortCode abort) { return static_cast<std::uint32_t>(abort); }

bool fits_expedited(SdoDownloadMode mode, std::size_t size) {
  return mode == SdoDownloadMode::kAuto && size > 0 && size <= kSdoExpeditedMax;
}

}  // namespace

SdoClient::SdoClient(FrameSink sink, SdoClientConfig defaults) : sink_(std::move(sink)), defaults_(defaults) {}

void SdoClient::configure_node(NodeId node, const SdoClientConfig& config) { channels_[node].config = config; }

const SdoClientConfig& SdoClient::config_of(const Channel& channel) const {
  return channel.config ? *channel.config : defaults_;
}

void SdoClient::upload(NodeId node, ObjectAddress object, SdoCallback done) {
  Transfer transfer;
  transfer.direction = Direction::kUpload;
  transfer.object = object;
  transfer.done = std::move(done);
  enqueue(node, std::move(transfer));
}

void SdoClient::download(NodeId node, ObjectAddress object, std::vector<std::uint8_t> data, SdoCallback done,
                         SdoDownloadMode mode) {
  Transfer transfer;
  transfer.direction = Direction::kDownload;
  transfer.object = object;
  transfer.data = std::move(data);
  transfer.done = std::move(done);
  transfer.mode = mode;
  enqueue(node, std::move(transfer));
}

void SdoClient::enqueue(NodeId node, Transfer transfer) {
  if (!is_valid_node_id(node) || transfer.data.size() > std::numeric_limits<std::uint32_t>::max()) {
    if (transfer.done) transfer.done(CanopenError::kInvalidArgument, {});
    return;
  }
  channels_[node].queue.push_back(std::move(transfer));
}

void SdoClient::cancel(NodeId node) {
  const auto it = channels_.find(node);
  if (it == channels_.end()) return;
  Channel& channel = it->second;
  std::deque<Transfer> dropped;
  if (channel.active) {
    if (sink_) sink_(sdo_request_frame(node, SdoAbort{channel.active->object, code(SdoAbortCode::kGeneralError)}));
    abandon(channel, channel.active->object);
    dropped.push_back(std::move(*channel.active));
    channel.active.reset();
  }
  std::move(channel.queue.begin(), channel.queue.end(), std::back_inserter(dropped));
  channel.queue.clear();
  for (auto& transfer : dropped) {
    if (transfer.done) transfer.done(CanopenError::kCancelled, {});
  }
}

bool SdoClient::on_frame(const can::Frame& frame, TimePoint now) {
  if (!detail::is_standard_data_frame(frame)) return false;
  const auto info = classify_cob_id(frame.id);
  if (!info || info->kind != MessageKind::kSdoResponse) return false;
  const auto it = channels_.find(info->node);
  if (it == channels_.end() || !it->second.active) return true;  // late or foreign reply
  const auto response = decode_sdo_response(frame.payload());
  if (!response) {
    fail(info->node, it->second, SdoAbortCode::kInvalidCommandSpecifier, code(SdoAbortCode::kInvalidCommandSpecifier),
         now);
    return true;
  }
  if (is_late_answer(it->second, *response)) return true;
  handle_response(info->node, it->second, *response, now);
  return true;
}

void SdoClient::abandon(Channel& channel, ObjectAddress object) {
  constexpr std::size_t kRemembered = 8;  // a bound for a channel that is never idle
  if (channel.abandoned.size() == kRemembered) channel.abandoned.erase(channel.abandoned.begin());
  channel.abandoned.push_back(object);
}

// An answer naming another object than the active transfer's, one whose request this client gave
// up: the server answered after the timeout (the abort crossed its answer on the bus).
bool SdoClient::is_late_answer(const Channel& channel, const SdoResponse& response) {
  const ObjectAddress* object = nullptr;
  if (const auto* upload = std::get_if<SdoInitiateUploadResponse>(&response)) object = &upload->object;
  if (const auto* download = std::get_if<SdoInitiateDownloadResponse>(&response)) object = &download->object;
  if (const auto* abort = std::get_if<SdoAbort>(&response)) object = &abort->object;
  if (object == nullptr || *object == channel.active->object) return false;
  return std::find(channel.abandoned.begin(), channel.abandoned.end(), *object) != channel.abandoned.end();
}

TimePoint SdoClient::process(TimePoint now) {
  for (auto& [node, channel] : channels_) {
    if (channel.active && now >= channel.active->deadline) handle_timeout(node, channel, now);
    if (!channel.active) start_next(node, channel, now);
  }
  return next_deadline();
}

TimePoint SdoClient::next_deadline() const {
  TimePoint next = kNever;
  for (const auto& [node, channel] : channels_) {
    if (channel.active) {
      next = std::min(next, channel.active->deadline);
    } else if (!channel.queue.empty()) {
      return TimePoint::min();
    }
  }
  return next;
}

bool SdoClient::busy(NodeId node) const {
  const auto it = channels_.find(node);
  return it != channels_.end() && it->second.active.has_value();
}

std::size_t SdoClient::pending(NodeId node) const {
  const auto it = channels_.find(node);
  if (it == channels_.end()) return 0;
  return it->second.queue.size() + (it->second.active ? 1u : 0u);
}

void SdoClient::start_next(NodeId node, Channel& channel, TimePoint now) {
  if (channel.active || channel.queue.empty()) return;
  channel.active = std::move(channel.queue.front());
  channel.queue.pop_front();
  send_initiate(node, channel, now);
}

void SdoClient::send_initiate(NodeId node, Channel& channel, TimePoint now) {
  Transfer& transfer = *channel.active;
  transfer.phase = Phase::kInitiate;
  transfer.toggle = false;
  transfer.offset = 0;
  transfer.expected.reset();
  if (transfer.direction == Direction::kUpload) {
    transfer.data.clear();
    send_request(node, channel, SdoInitiateUploadRequest{transfer.object}, now);
    return;
  }
  const SdoInitiateData initiate =
      fits_expedited(transfer.mode, transfer.data.size())
          ? SdoInitiateData::expedited_data(transfer.object, *InlineBytes<kSdoExpeditedMax>::from(transfer.data))
          : SdoInitiateData::segmented(transfer.object, static_cast<std::uint32_t>(transfer.data.size()));
  send_request(node, channel, SdoInitiateDownloadRequest{initiate}, now);
}

void SdoClient::send_request(NodeId node, Channel& channel, const SdoRequest& request, TimePoint now) {
  channel.active->deadline = now + config_of(channel).timeout;
  if (sink_) sink_(sdo_request_frame(node, request));
}

void SdoClient::send_next_download_segment(NodeId node, Channel& channel, TimePoint now) {
  Transfer& transfer = *channel.active;
  const std::size_t chunk = std::min(kSdoSegmentMax, transfer.data.size() - transfer.offset);
  const auto bytes = std::span<const std::uint8_t>(transfer.data).subspan(transfer.offset, chunk);
  transfer.offset += chunk;
  const bool last = transfer.offset == transfer.data.size();
  send_request(node, channel,
               SdoDownloadSegmentRequest{{transfer.toggle, last, *InlineBytes<kSdoSegmentMax>::from(bytes)}}, now);
}

void SdoClient::handle_response(NodeId node, Channel& channel, const SdoResponse& response, TimePoint now) {
  Transfer& transfer = *channel.active;
  if (const auto* abort = std::get_if<SdoAbort>(&response)) {
    complete(node, channel, sdo_abort_error(abort->code), now);
    return;
  }
  const auto protocol_error = [&] {
    fail(node, channel, SdoAbortCode::kInvalidCommandSpecifier, code(SdoAbortCode::kInvalidCommandSpecifier), now);
  };
  const auto wrong_object = [&](ObjectAddress object) {
    if (object == transfer.object) return false;
    fail(node, channel, CanopenError::kMismatchedReply, code(SdoAbortCode::kGeneralError), now);
    return true;
  };
  const auto wrong_toggle = [&](bool toggle) {
    if (toggle == transfer.toggle) return false;
    fail(node, channel, SdoAbortCode::kToggleBitNotAlternated, code(SdoAbortCode::kToggleBitNotAlternated), now);
    return true;
  };
  const std::size_t max_upload = config_of(channel).max_upload_size;

  if (transfer.direction == Direction::kUpload && transfer.phase == Phase::kInitiate) {
    const auto* initiate = std::get_if<SdoInitiateUploadResponse>(&response);
    if (!initiate) return protocol_error();
    if (wrong_object(initiate->object)) return;
    if (initiate->expedited) {
      const auto data = initiate->data.view();
      transfer.data.assign(data.begin(), data.end());
      return succeed(node, channel, now);
    }
    if (initiate->size_indicated) {
      if (initiate->total_size > max_upload) {
        return fail(node, channel, SdoAbortCode::kOutOfMemory, code(SdoAbortCode::kOutOfMemory), now);
      }
      transfer.expected = initiate->total_size;
    }
    transfer.phase = Phase::kSegments;
    return send_request(node, channel, SdoUploadSegmentRequest{transfer.toggle}, now);
  }

  if (transfer.direction == Direction::kUpload) {
    const auto* segment = std::get_if<SdoUploadSegmentResponse>(&response);
    if (!segment) return protocol_error();
    if (wrong_toggle(segment->toggle)) return;
    const auto data = segment->data.view();
    transfer.data.insert(transfer.data.end(), data.begin(), data.end());
    if (transfer.expected && transfer.data.size() > *transfer.expected) {
      return fail(node, channel, SdoAbortCode::kLengthTooHigh, code(SdoAbortCode::kLengthTooHigh), now);
    }
    if (transfer.data.size() > max_upload) {
      return fail(node, channel, SdoAbortCode::kOutOfMemory, code(SdoAbortCode::kOutOfMemory), now);
    }
    if (segment->last) {
      if (transfer.expected && transfer.data.size() < *transfer.expected) {
        return fail(node, channel, SdoAbortCode::kLengthTooLow, code(SdoAbortCode::kLengthTooLow), now);
      }
      return succeed(node, channel, now);
    }
    transfer.toggle = !transfer.toggle;
    return send_request(node, channel, SdoUploadSegmentRequest{transfer.toggle}, now);
  }

  if (transfer.phase == Phase::kInitiate) {
    const auto* initiate = std::get_if<SdoInitiateDownloadResponse>(&response);
    if (!initiate) return protocol_error();
    if (wrong_object(initiate->object)) return;
    if (fits_expedited(transfer.mode, transfer.data.size())) return succeed(node, channel, now);
    transfer.phase = Phase::kSegments;
    return send_next_download_segment(node, channel, now);
  }

  const auto* segment = std::get_if<SdoDownloadSegmentResponse>(&response);
  if (!segment) return protocol_error();
  if (wrong_toggle(segment->toggle)) return;
  if (transfer.offset == transfer.data.size()) return succeed(node, channel, now);
  transfer.toggle = !transfer.toggle;
  send_next_download_segment(node, channel, now);
}

void SdoClient::handle_timeout(NodeId node, Channel& channel, TimePoint now) {
  Transfer& transfer = *channel.active;
  if (sink_) sink_(sdo_request_frame(node, SdoAbort{transfer.object, code(SdoAbortCode::kTimeout)}));
  abandon(channel, transfer.object);
  if (transfer.attempt < config_of(channel).max_retries) {
    ++transfer.attempt;
    send_initiate(node, channel, now);
    return;
  }
  complete(node, channel, SdoAbortCode::kTimeout, now);
}

void SdoClient::fail(NodeId node, Channel& channel, std::error_code error, std::optional<std::uint32_t> wire_code,
                     TimePoint now) {
  if (wire_code && sink_) sink_(sdo_request_frame(node, SdoAbort{channel.active->object, *wire_code}));
  complete(node, channel, error, now);
}

void SdoClient::succeed(NodeId node, Channel& channel, TimePoint now) { complete(node, channel, {}, now); }

void SdoClient::complete(NodeId node, Channel& channel, std::error_code error, TimePoint now) {
  Transfer finished = std::move(*channel.active);
  channel.active.reset();
  if (finished.done) {
    const bool with_data = !error && finished.direction == Direction::kUpload;
    finished.done(error, with_data ? std::span<const std::uint8_t>(finished.data) : std::span<const std::uint8_t>{});
  }
  start_next(node, channel, now);
  if (!channel.active) channel.abandoned.clear();  // late answers are dropped as "no transfer" now
}

}  // namespace motion::canopen
