#include "motion/simbus/wire.hpp"

#include <algorithm>

#include "motion/core/bytes.hpp"

namespace motion::simbus::wire {
namespace {

constexpr std::uint8_t kFlagExtended = 0x01;
constexpr std::uint8_t kFlagRtr = 0x02;
constexpr std::uint8_t kFlagOwnEcho = 0x04;

// Appends fields to a span; remembers when anything did not fit.
class Writer {
 public:
  explicit Writer(std::span<std::uint8_t> out) : out_(out) {}
  template <typename T>
  void le(T value) {
    ok_ = ok_ && bytes::write_le<T>(out_, size_, value);
    size_ += sizeof(T);
  }
  void u8(std::uint8_t value) { le(value); }
  void text(const std::string& s) {
    const std::size_t n = std::min(s.size(), kMaxText);
    u8(static_cast<std::uint8_t>(n));
    ok_ = ok_ && size_ + n <= out_.size();
    if (ok_) std::copy_n(s.begin(), n, out_.begin() + static_cast<std::ptrdiff_t>(size_));
    size_ += n;
  }
  void raw(std::span<const std::uint8_t> data) {
    ok_ = ok_ && size_ + data.size() <= out_.size();
    if (ok_) std::copy(data.begin(), data.end(), out_.begin() + static_cast<std::ptrdiff_t>(size_));
    size_ += data.size();
  }
  [[nodiscard]] std::size_t finish() const { return ok_ ? size_ : 0; }

 private:
  std::span<std::uint8_t> out_;
  std::size_t size_ = 0;
  bool ok_ = true;
};

// Reads fields in order; any short read poisons the result.
class Reader {
 public:
  explicit Reader(std::span<const std::uint8_t> in) : in_(in) {}
  template <typename T>
  T le() {
    const auto v = bytes::read_le<T>(in_, pos_);
    pos_ += sizeof(T);
    if (!v) ok_ = false;
    return v.value_or(T{});
  }
  std::uint8_t u8() { return le<std::uint8_t>(); }
  std::string text() {
    const std::size_t n = u8();
    if (!ok_ || pos_ + n > in_.size()) {
      ok_ = false;
      return {};
    }
    std::string s(in_.begin() + static_cast<std::ptrdiff_t>(pos_), in_.begin() + static_cast<std::ptrdiff_t>(pos_ + n));
    pos_ += n;
    return s;
  }
  // The next `out.size()` bytes.
  void raw(std::span<std::uint8_t> out) {
    if (!ok_ || pos_ + out.size() > in_.size()) {
      ok_ = false;
      return;
    }
    std::copy_n(in_.begin() + static_cast<std::ptrdiff_t>(pos_), out.size(), out.begin());
    pos_ += out.size();
  }
  [[nodiscard]] std::span<const std::uint8_t> rest() const {
    return pos_ <= in_.size() ? in_.subspan(pos_) : std::span<const std::uint8_t>{};
  }
  // True when every read succeeded and exactly the whole datagram was consumed.
  [[nodiscard]] bool complete(std::size_t trailing = 0) const { return ok_ && pos_ + trailing == in_.size(); }

 private:
  std::span<const std::uint8_t> in_;
  std::size_t pos_ = 0;
  bool ok_ = true;
};

bool valid(const can::Frame& f) {
  return f.dlc <= 8 && f.id <= (f.extended ? can::kMaxExtendedId : can::kMaxStandardId);
}

std::size_t on_wire_data_bytes(const can::Frame& f) { return f.rtr ? 0 : f.dlc; }

struct Encoder {
  Writer& w;
  void operator()(const Hello& m) {
    w.u8(static_cast<std::uint8_t>(Type::kHello));
    w.le(m.version);
    w.u8(m.own_echo ? 1 : 0);
    w.text(m.label);
  }
  void operator()(const Welcome& m) {
    w.u8(static_cast<std::uint8_t>(Type::kWelcome));
    w.le(m.version);
    w.le(m.endpoint);
    w.le(m.bitrate);
    w.text(m.bus_name);
  }
  void operator()(const FrameMessage& m) {
    const can::Frame& f = m.frame;
    w.u8(static_cast<std::uint8_t>(Type::kFrame));
    w.u8(static_cast<std::uint8_t>((f.extended ? kFlagExtended : 0) | (f.rtr ? kFlagRtr : 0) |
                                   (m.own_echo ? kFlagOwnEcho : 0)));
    w.u8(f.dlc);
    w.u8(0);
    w.le(f.id);
    w.le(f.timestamp_us);
    w.raw({f.data.data(), on_wire_data_bytes(f)});
  }
  void operator()(const SetOwnEcho& m) {
    w.u8(static_cast<std::uint8_t>(Type::kSetOwnEcho));
    w.u8(m.enabled ? 1 : 0);
  }
  void operator()(const BusEventMessage& m) {
    w.u8(static_cast<std::uint8_t>(Type::kBusEvent));
    w.u8(static_cast<std::uint8_t>(m.event.state));
    w.le(m.event.error_class);
    w.text(m.event.text);
  }
  void operator()(const FrameBatch& m) {
    w.u8(static_cast<std::uint8_t>(Type::kFrameBatch));
    w.u8(static_cast<std::uint8_t>(m.count));
    for (const can::Frame& f : m.view()) {
      w.u8(static_cast<std::uint8_t>((f.extended ? kFlagExtended : 0) | (f.rtr ? kFlagRtr : 0)));
      w.u8(f.dlc);
      w.le(f.id);
      w.raw({f.data.data(), on_wire_data_bytes(f)});
    }
  }
  void operator()(const TxRejected& m) {
    w.u8(static_cast<std::uint8_t>(Type::kTxRejected));
    w.u8(m.extended ? kFlagExtended : 0);
    w.le(m.id);
  }
};

std::optional<bool> decode_bool(std::uint8_t v) {
  if (v > 1) return std::nullopt;
  return v == 1;
}

std::optional<Message> decode_frame(Reader& r) {
  FrameMessage m;
  const std::uint8_t flags = r.u8();
  m.frame.dlc = r.u8();
  const std::uint8_t reserved = r.u8();
  m.frame.id = r.le<std::uint32_t>();
  m.frame.timestamp_us = r.le<std::int64_t>();
  if ((flags & ~(kFlagExtended | kFlagRtr | kFlagOwnEcho)) != 0 || reserved != 0) return std::nullopt;
  m.frame.extended = (flags & kFlagExtended) != 0;
  m.frame.rtr = (flags & kFlagRtr) != 0;
  m.own_echo = (flags & kFlagOwnEcho) != 0;
  if (!valid(m.frame)) return std::nullopt;
  const std::size_t n = on_wire_data_bytes(m.frame);
  if (!r.complete(n)) return std::nullopt;
  const auto data = r.rest();
  std::copy_n(data.begin(), n, m.frame.data.begin());
  return m;
}

std::optional<Message> decode_batch(Reader& r) {
  FrameBatch m;
  m.count = r.u8();
  if (m.count == 0 || m.count > kMaxBatchFrames) return std::nullopt;
  for (can::Frame& f : std::span(m.frames).first(m.count)) {
    const std::uint8_t flags = r.u8();
    f.dlc = r.u8();
    f.id = r.le<std::uint32_t>();
    if ((flags & ~(kFlagExtended | kFlagRtr)) != 0) return std::nullopt;
    f.extended = (flags & kFlagExtended) != 0;
    f.rtr = (flags & kFlagRtr) != 0;
    if (!valid(f)) return std::nullopt;
    r.raw(std::span(f.data).first(on_wire_data_bytes(f)));
  }
  if (!r.complete()) return std::nullopt;
  return m;
}

bool encodable(const Message& message) {
  if (const auto* fm = std::get_if<FrameMessage>(&message)) return valid(fm->frame);
  if (const auto* batch = std::get_if<FrameBatch>(&message)) {
    return batch->count > 0 && batch->count <= kMaxBatchFrames && std::ranges::all_of(batch->view(), valid);
  }
  return true;
}

}  // namespace

std::size_t encode(const Message& message, std::span<std::uint8_t> out) {
  if (!encodable(message)) return 0;
  Writer w(out);
  std::visit(Encoder{w}, message);
  return w.finish();
}

std::optional<Message> decode(std::span<const std::uint8_t> in) {
  if (in.empty()) return std::nullopt;
  Reader r(in);
  const auto type = static_cast<Type>(r.u8());
  std::optional<Message> out;
  switch (type) {
    case Type::kHello: {
      Hello m;
      m.version = r.le<std::uint16_t>();
      const auto echo = decode_bool(r.u8());
      m.label = r.text();
      if (!echo) return std::nullopt;
      m.own_echo = *echo;
      out = std::move(m);
      break;
    }
    case Type::kWelcome: {
      Welcome m;
      m.version = r.le<std::uint16_t>();
      m.endpoint = r.le<std::uint32_t>();
      m.bitrate = r.le<std::uint32_t>();
      m.bus_name = r.text();
      out = std::move(m);
      break;
    }
    case Type::kFrame: return decode_frame(r);
    case Type::kFrameBatch: return decode_batch(r);
    case Type::kSetOwnEcho: {
      const auto enabled = decode_bool(r.u8());
      if (!enabled) return std::nullopt;
      out = SetOwnEcho{*enabled};
      break;
    }
    case Type::kBusEvent: {
      BusEventMessage m;
      const std::uint8_t state = r.u8();
      if (state > static_cast<std::uint8_t>(can::BusState::kDisconnected)) return std::nullopt;
      m.event.state = static_cast<can::BusState>(state);
      m.event.error_class = r.le<std::uint32_t>();
      m.event.text = r.text();
      out = std::move(m);
      break;
    }
    case Type::kTxRejected: {
      TxRejected m;
      const std::uint8_t flags = r.u8();
      m.id = r.le<std::uint32_t>();
      if ((flags & ~kFlagExtended) != 0) return std::nullopt;
      m.extended = (flags & kFlagExtended) != 0;
      out = m;
      break;
    }
    default: return std::nullopt;
  }
  if (!r.complete()) return std::nullopt;
  return out;
}

}  // namespace motion::simbus::wire
