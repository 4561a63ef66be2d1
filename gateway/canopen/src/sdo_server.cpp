#include "motion/canopen/sdo_server.hpp"

#include <algorithm>
#include <variant>

#include "frame_util.hpp"
#include "motion/canopen/cob_id.hpp"
#include "motion/canopen/sdo.hpp"

namespace motion::canopen {

SdoServer::SdoServer(NodeId node, FrameSink sink, SdoServerHandlers handlers, SdoServerConfig config)
    : node_(node), sink_(std::move(sink)), handlers_(std::move(handlers)), config_(config) {}

bool SdoServer::on_request(const can::Frame& frame, TimePoint now) {
  if (!detail::is_standard_data_frame(frame) || frame.id != sdo_request_cob_id(node_)) return false;
  const auto request = decode_sdo_request(frame.payload());
  if (!request) {
    // Wrong length or an unknown/block command: answer with the multiplexer the frame carries.
    const auto bytes = frame.payload();
    ObjectAddress object;
    if (bytes.size() >= 4) object = {static_cast<std::uint16_t>(bytes[1] | (bytes[2] << 8)), bytes[3]};
    transfer_.reset();
    abort(object, SdoAbortCode::kInvalidCommandSpecifier);
    return true;
  }
  if (const auto* client_abort = std::get_if<SdoAbort>(&*request)) {
    (void)client_abort;
    transfer_.reset();  // CiA 301: an abort is not confirmed
  } else if (const auto* download = std::get_if<SdoInitiateDownloadRequest>(&*request)) {
    on_initiate_download(*download, now);
  } else if (const auto* segment = std::get_if<SdoDownloadSegmentRequest>(&*request)) {
    on_download_segment(*segment, now);
  } else if (const auto* upload = std::get_if<SdoInitiateUploadRequest>(&*request)) {
    on_initiate_upload(upload->object, now);
  } else if (const auto* upload_segment = std::get_if<SdoUploadSegmentRequest>(&*request)) {
    on_upload_segment(upload_segment->toggle, now);
  }
  return true;
}

TimePoint SdoServer::process(TimePoint now) {
  if (transfer_ && now >= transfer_->deadline) {
    const ObjectAddress object = transfer_->object;
    transfer_.reset();
    abort(object, SdoAbortCode::kTimeout);
  }
  return next_deadline();
}

void SdoServer::abort(ObjectAddress object, SdoAbortCode code) {
  if (sink_) sink_(sdo_response_frame(node_, SdoAbort{object, static_cast<std::uint32_t>(code)}));
}

void SdoServer::on_initiate_download(const SdoInitiateDownloadRequest& request, TimePoint now) {
  transfer_.reset();  // a new initiate replaces a half-done transfer
  if (request.expedited) {
    const auto refused = handlers_.write
                             ? handlers_.write({request.object, request.data.view(), request.size_indicated})
                             : std::optional<SdoAbortCode>{SdoAbortCode::kUnsupportedAccess};
    if (refused) return abort(request.object, *refused);
    if (sink_) sink_(sdo_response_frame(node_, SdoInitiateDownloadResponse{request.object}));
    return;
  }
  Transfer transfer;
  transfer.direction = Direction::kDownload;
  transfer.object = request.object;
  if (request.size_indicated) transfer.announced = request.total_size;
  transfer.deadline = now + config_.segment_timeout;
  transfer_ = std::move(transfer);
  if (sink_) sink_(sdo_response_frame(node_, SdoInitiateDownloadResponse{request.object}));
}

void SdoServer::on_download_segment(const SdoDownloadSegmentRequest& request, TimePoint now) {
  if (!transfer_ || transfer_->direction != Direction::kDownload) {
    const ObjectAddress object = transfer_ ? transfer_->object : ObjectAddress{};
    transfer_.reset();
    return abort(object, SdoAbortCode::kInvalidCommandSpecifier);
  }
  Transfer& transfer = *transfer_;
  const ObjectAddress object = transfer.object;
  if (request.toggle != transfer.toggle) {
    transfer_.reset();
    return abort(object, SdoAbortCode::kToggleBitNotAlternated);
  }
  const auto bytes = request.data.view();
  transfer.data.insert(transfer.data.end(), bytes.begin(), bytes.end());
  if (transfer.announced && transfer.data.size() > *transfer.announced) {
    transfer_.reset();
    return abort(object, SdoAbortCode::kLengthMismatch);
  }
  const bool toggle = transfer.toggle;
  if (!request.last) {
    transfer.toggle = !transfer.toggle;
    transfer.deadline = now + config_.segment_timeout;
    if (sink_) sink_(sdo_response_frame(node_, SdoDownloadSegmentResponse{toggle}));
    return;
  }
  const Transfer finished = std::move(transfer);
  transfer_.reset();
  if (finished.announced && finished.data.size() != *finished.announced) {
    return abort(object, SdoAbortCode::kLengthMismatch);
  }
  const auto refused = handlers_.write ? handlers_.write({object, finished.data, true})
                                       : std::optional<SdoAbortCode>{SdoAbortCode::kUnsupportedAccess};
  if (refused) return abort(object, *refused);
  if (sink_) sink_(sdo_response_frame(node_, SdoDownloadSegmentResponse{toggle}));
}

void SdoServer::on_initiate_upload(ObjectAddress object, TimePoint now) {
  transfer_.reset();
  SdoReadResult result = handlers_.read ? handlers_.read(object) : SdoReadResult{{}, SdoAbortCode::kUnsupportedAccess};
  if (result.abort) return abort(object, *result.abort);
  const bool expedited = !config_.segmented_uploads && !result.data.empty() && result.data.size() <= kSdoExpeditedMax;
  if (expedited) {
    const auto data = *InlineBytes<kSdoExpeditedMax>::from(result.data);
    if (sink_)
      sink_(sdo_response_frame(node_, SdoInitiateUploadResponse{SdoInitiateData::expedited_data(object, data)}));
    return;
  }
  Transfer transfer;
  transfer.direction = Direction::kUpload;
  transfer.object = object;
  transfer.data = std::move(result.data);
  transfer.deadline = now + config_.segment_timeout;
  const auto size = static_cast<std::uint32_t>(transfer.data.size());
  transfer_ = std::move(transfer);
  if (sink_) sink_(sdo_response_frame(node_, SdoInitiateUploadResponse{SdoInitiateData::segmented(object, size)}));
}

void SdoServer::on_upload_segment(bool toggle, TimePoint now) {
  if (!transfer_ || transfer_->direction != Direction::kUpload) {
    const ObjectAddress object = transfer_ ? transfer_->object : ObjectAddress{};
    transfer_.reset();
    return abort(object, SdoAbortCode::kInvalidCommandSpecifier);
  }
  Transfer& transfer = *transfer_;
  if (toggle != transfer.toggle) {
    const ObjectAddress object = transfer.object;
    transfer_.reset();
    return abort(object, SdoAbortCode::kToggleBitNotAlternated);
  }
  const std::size_t chunk = std::min(kSdoSegmentMax, transfer.data.size() - transfer.offset);
  const auto bytes = std::span<const std::uint8_t>(transfer.data).subspan(transfer.offset, chunk);
  transfer.offset += chunk;
  const bool last = transfer.offset == transfer.data.size();
  const SdoUploadSegmentResponse response{{toggle, last, *InlineBytes<kSdoSegmentMax>::from(bytes)}};
  transfer.toggle = !transfer.toggle;
  transfer.deadline = now + config_.segment_timeout;
  if (last) transfer_.reset();
  if (sink_) sink_(sdo_response_frame(node_, response));
}

}  // namespace motion::canopen
