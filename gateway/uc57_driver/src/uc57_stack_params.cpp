// Uc57Stack (uc57_stack.hpp): expert parameters (PARAM_READ, PARAM_WRITE as CANopen objects), and
// the objects the drive model is made of (2006h resolution, 200Eh start speed; manual §5.1): read
// at set-up, read again after a PARAM_WRITE of either, and reported to the gateway (DriveFacts).
#include "uc57_stack_impl.hpp"

namespace motion::uc57_driver {

bool Uc57Stack::is_model_object(ObjectAddress object) {
  return object.subindex == 0 && (object.index == od::kMicrostepping || object.index == od::kStartSpeed);
}

std::optional<std::pair<std::int32_t, std::string>> Uc57Stack::refuse_model_write(
    std::size_t n, const motionlcm::param_t& param) const {
  if (param.space != motionlcm::param_t::CANOPEN_OBJECT || param.subindex > 0) return std::nullopt;
  if (param.index != od::kMicrostepping && param.index != od::kStartSpeed) return std::nullopt;
  const Node& node = *nodes_[n];
  const bool in_motion =
      node.task != TaskKind::kNone && node.task != TaskKind::kSdoOnly && node.task != TaskKind::kPower;
  if (!in_motion && !node.status.moving) return std::nullopt;
  const std::string what = param.index == od::kMicrostepping ? "2006h (resolution)" : "200Eh (start speed)";
  const bool armed = node.task == TaskKind::kArming || node.task == TaskKind::kArmed;
  const std::string doing = armed ? "has a move armed" : "is moving";
  return std::pair{error_code(ReplyError::kAxisBusy),
                   node.settings.label() + ": " + what + " cannot be written while the axis " + doing +
                       (node.task == TaskKind::kNone ? "" : " (command " + std::to_string(node.task_command) + ")") +
                       ": the move was planned with the present value; stop it first"};
}

void Uc57Stack::reread_model_objects(std::size_t n, Continue done) {
  const unsigned session = nodes_[n]->session;
  sdo_read(n, {od::kMicrostepping, 0},
           [this, n, session, done = std::move(done)](std::error_code ec, std::span<const std::uint8_t> data) mutable {
             if (ec) return done(sdo_failure(n, false, {od::kMicrostepping, 0}, ec));
             const auto code = static_cast<std::uint16_t>(read_unsigned(data));
             const auto ppr = cia402::uc57::pulses_per_revolution(code);
             if (!ppr) {
               return done(nodes_[n]->settings.label() + ": 2006h holds an unknown subdivision code " +
                           std::to_string(code));
             }
             sdo_read(n, {od::kStartSpeed, 0},
                      [this, n, session, ppr = *ppr, done = std::move(done)](std::error_code ec2,
                                                                             std::span<const std::uint8_t> rpm) {
                        if (ec2) return done(sdo_failure(n, false, {od::kStartSpeed, 0}, ec2));
                        Node& node = *nodes_[n];
                        if (node.session == session) {  // a new set-up reads and reports them itself
                          node.pulses_per_rev = ppr;
                          node.start_speed =
                              cia402::uc57::rpm_to_pulses_per_second(static_cast<double>(read_unsigned(rpm)), ppr);
                          report_facts(n);
                        }
                        done(std::nullopt);
                      });
           });
}

void Uc57Stack::report_facts(std::size_t n) {
  const Node& node = *nodes_[n];
  if (context_.out == nullptr || node.settings.axis.empty()) return;
  gateway::DriveFacts facts;
  facts.counts_per_revolution = node.pulses_per_rev;
  facts.start_speed_rpm = node.start_speed * 60.0 / node.pulses_per_rev;
  facts.one_frame_start = node.rpdo_at_sync;  // false: no synchronous RPDO start (uc57_stack_rpdo.cpp)
  facts.drive_keeps_homed = true;             // status word bit 8, homing attained (manual §4.2.6)
  context_.out->drive_facts(node.settings.axis, facts);
}

void Uc57Stack::start_param(std::size_t n, Job& job) {
  const std::int64_t id = job.command.command_id;
  const motionlcm::param_t& param = job.command.param;
  const std::string label = nodes_[n]->settings.label();
  if (param.space != motionlcm::param_t::CANOPEN_OBJECT) {
    return part_failed(id, n, error_code(ReplyError::kMalformedRequest),
                       label + ": UC57 parameters are CANopen objects (param_t space CANOPEN_OBJECT)");
  }
  if (param.index < 0 || param.index > 0xFFFF || param.subindex < -1 || param.subindex > 0xFF) {
    return part_failed(id, n, error_code(ReplyError::kMalformedRequest),
                       label + ": object " + std::to_string(param.index) + ":" + std::to_string(param.subindex) +
                           " is not a CANopen index (0..FFFFh) and sub-index (0..FFh)");
  }
  const ObjectAddress object{static_cast<std::uint16_t>(param.index),
                             static_cast<std::uint8_t>(std::max(param.subindex, 0))};
  const auto* entry = cia402::uc57::find_entry(object.index, object.subindex);
  std::size_t width = static_cast<std::size_t>(std::max<std::int8_t>(param.width, 0));
  bool is_signed = param.is_signed;
  if (width == 0 && entry != nullptr) {
    width = cia402::uc57::size_bytes(entry->type);
    is_signed = cia402::uc57::is_signed(entry->type);
  }
  if (width != 0 && width != 1 && width != 2 && width != 4) {
    return part_failed(id, n, error_code(ReplyError::kMalformedRequest),
                       label + ": width " + std::to_string(width) + " (CANopen objects: 1, 2 or 4 bytes)");
  }
  if (job.command.kind == Command::PARAM_READ) {
    return sdo_read(
        n, object, [this, n, id, object, is_signed](std::error_code ec, std::span<const std::uint8_t> data) {
          if (ec) return part_failed(id, n, error_code(ReplyError::kDriveError), sdo_failure(n, false, object, ec));
          if (Job* live = jobs_.find(id)) {
            auto value = live->reply.peek().param;
            value.value = is_signed ? read_signed(data) : static_cast<std::int64_t>(read_unsigned(data));
            live->reply.param(value);
          }
          part_done(id, n);
        });
  }
  if (width == 0) {
    return part_failed(id, n, error_code(ReplyError::kMalformedRequest),
                       label + ": object " + object_text(object) + " is not in the UC57 dictionary: give the width");
  }
  std::vector<std::uint8_t> data(width);
  for (std::size_t i = 0; i < width; ++i)
    data[i] = static_cast<std::uint8_t>(static_cast<std::uint64_t>(param.value) >> (8 * i));
  sdo_write(n, object, data, [this, n, id, object](std::error_code ec, std::span<const std::uint8_t>) {
    if (ec) return part_failed(id, n, error_code(ReplyError::kDriveError), sdo_failure(n, true, object, ec));
    if (!is_model_object(object)) return part_done(id, n);
    // The drive's resolution or start speed changed: read both back, so that the drive model the
    // gateway republishes (and this stack's own conversions) are the drive's again.
    reread_model_objects(n, [this, n, id](std::optional<std::string> failure) {
      if (failure) return part_failed(id, n, error_code(ReplyError::kDriveError), *failure);
      part_done(id, n);
    });
  });
}

}  // namespace motion::uc57_driver
