// Which CRC coverage a UIROBOT serial gateway uses (docs/protocols.md, UIMessage row 1): the UIM342
// manual (§2.6, Appendix-1) says the CRC covers the 13 bytes SM..d8; UIROBOT's own gateway software
// covers the 12 bytes ID..d8. A gateway that checks the other coverage drops our frames without a
// word, so the send side follows what the gateway's frames use:
//   - configured (uimessage_crc: 12 | 13): that coverage, always; nothing is detected.
//   - detect (the default): start with the manual's 13 bytes (or a given start). Every received frame with a CRC
//     tells the gateway's coverage (it computes what it checks); the send side switches to it at
//     once. While no frame has ever come back, `unanswered_limit` frames sent in a row without
//     an answer switch to the other coverage (the gateway may be dropping them all), and back
//     again after as many more, so detection converges even when only our frames can start the
//     exchange. Once a frame has come back, silence changes nothing (the drives may be off).
// Pure logic, no I/O. Thread contract: one owner thread.
#pragma once

#include <cstdint>
#include <string>

#include "motion/uim342/uimessage.hpp"

namespace motion::uimessage {

class CrcDetector {
 public:
  static constexpr unsigned kDefaultUnansweredLimit = 4;

  // `detect` false: send `start` always (configured); true: start with it and detect.
  CrcDetector(uim342::CrcCoverage start, bool detect, unsigned unanswered_limit = kDefaultUnansweredLimit);

  // The coverage of the next frame sent; counts it as unanswered until a frame comes back.
  uim342::CrcCoverage next_send();
  // A received frame whose CRC matched `coverage` (from decode_ui_message). True when this
  // changed what the send side uses or decided it for the first time (worth reporting).
  bool on_received(uim342::CrcCoverage coverage);

  [[nodiscard]] uim342::CrcCoverage sending() const { return sending_; }
  [[nodiscard]] bool configured() const { return configured_; }
  [[nodiscard]] bool detected() const { return detected_; }
  // Switches made while guessing (no answer yet); for statistics and tests.
  [[nodiscard]] unsigned blind_switches() const { return blind_switches_; }
  // "ID..d8 (12 bytes), detected from the gateway's replies" / "... configured" / "... not known
  // yet (nothing answered)".
  [[nodiscard]] std::string describe() const;

 private:
  uim342::CrcCoverage sending_ = uim342::CrcCoverage::kStartToAux;
  bool configured_ = false;
  bool detected_ = false;
  unsigned unanswered_limit_;
  unsigned unanswered_ = 0;
  unsigned blind_switches_ = 0;
};

// "SM..d8 (13 bytes)" / "ID..d8 (12 bytes)".
[[nodiscard]] std::string to_string(uim342::CrcCoverage coverage);

}  // namespace motion::uimessage
