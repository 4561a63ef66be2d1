#include "motion/uimessage/crc_detector.hpp"

namespace motion::uimessage {
namespace {

uim342::CrcCoverage other(uim342::CrcCoverage coverage) {
  return coverage == uim342::CrcCoverage::kStartToAux ? uim342::CrcCoverage::kIdToAux
                                                      : uim342::CrcCoverage::kStartToAux;
}

}  // namespace

std::string to_string(uim342::CrcCoverage coverage) {
  return coverage == uim342::CrcCoverage::kStartToAux ? "SM..d8 (13 bytes)" : "ID..d8 (12 bytes)";
}

CrcDetector::CrcDetector(uim342::CrcCoverage start, bool detect, unsigned unanswered_limit)
    : sending_(start), configured_(!detect), unanswered_limit_(unanswered_limit == 0 ? 1 : unanswered_limit) {}

uim342::CrcCoverage CrcDetector::next_send() {
  if (!configured_ && !detected_ && unanswered_ >= unanswered_limit_) {
    sending_ = other(sending_);
    unanswered_ = 0;
    ++blind_switches_;
  }
  ++unanswered_;
  return sending_;
}

bool CrcDetector::on_received(uim342::CrcCoverage coverage) {
  unanswered_ = 0;
  if (configured_) return false;
  const bool news = !detected_ || coverage != sending_;
  detected_ = true;
  sending_ = coverage;
  return news;
}

std::string CrcDetector::describe() const {
  if (configured_) return to_string(sending_) + ", configured (uimessage_crc)";
  if (detected_) return to_string(sending_) + ", detected from the gateway's frames";
  return "not known yet (no frame with a CRC has come back; sending " + to_string(sending_) + ")";
}

}  // namespace motion::uimessage
