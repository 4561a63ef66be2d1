// CiA 301 SDO codec against every SDO frame of the UC57 manual (M-, P-, V-, H-: §4.2.2,
// §4.2.4-§4.2.6) and derived vectors (CiA 301 §7.2.4.3: expedited D-01..D-11, D-19, aborts
// D-20..D-25, segmented D-26..D-28, PDO configuration D-31..D-37, appendix frames of manual §7).
// Decoders refuse short frames, trailing bytes and block-transfer command specifiers.
#include <gtest/gtest.h>

#include <cstdint>
#include <variant>
#include <vector>

#include "frame_text.hpp"
#include "motion/canopen/errors.hpp"
#include "motion/canopen/sdo.hpp"

namespace motion::canopen {
namespace {

using test::frame;
using test::payload;

// One confirmed write: the request, the server's reply, and what the request means.
struct DownloadVector {
  const char* id;
  const char* request;
  const char* reply;
  ObjectAddress object;
  std::vector<std::uint8_t> data;
};

std::vector<DownloadVector> manual_downloads() {
  return {
      // §4.2.2 power-on initialisation
      {"M-02", "601: 2B 40 60 00 00 00 00 00", "581: 60 40 60 00 00 00 00 00", {0x6040, 0}, {0x00, 0x00}},
      {"M-03", "601: 2B 40 60 00 06 00 00 00", "581: 60 40 60 00 00 00 00 00", {0x6040, 0}, {0x06, 0x00}},
      {"M-04", "601: 2B 40 60 00 07 00 00 00", "581: 60 40 60 00 00 00 00 00", {0x6040, 0}, {0x07, 0x00}},
      {"M-05", "601: 2B 40 60 00 0F 00 00 00", "581: 60 40 60 00 00 00 00 00", {0x6040, 0}, {0x0F, 0x00}},
      // §4.2.4 profile position, relative move
      {"P-02", "601: 2B 40 60 00 00 00 00 00", "581: 60 40 60 00 00 00 00 00", {0x6040, 0}, {0x00, 0x00}},
      {"P-03", "601: 23 83 60 00 64 00 00 00", "581: 60 83 60 00 00 00 00 00", {0x6083, 0}, {0x64, 0, 0, 0}},
      {"P-04", "601: 23 84 60 00 64 00 00 00", "581: 60 84 60 00 00 00 00 00", {0x6084, 0}, {0x64, 0, 0, 0}},
      {"P-05", "601: 23 81 60 00 3C 00 00 00", "581: 60 81 60 00 00 00 00 00", {0x6081, 0}, {0x3C, 0, 0, 0}},
      {"P-06", "601: 23 7A 60 00 88 13 00 00", "581: 60 7A 60 00 00 00 00 00", {0x607A, 0}, {0x88, 0x13, 0, 0}},
      {"P-07", "601: 2F 60 60 00 01 00 00 00", "581: 60 60 60 00 00 00 00 00", {0x6060, 0}, {0x01}},
      {"P-08", "601: 2B 40 60 00 06 00 00 00", "581: 60 40 60 00 00 00 00 00", {0x6040, 0}, {0x06, 0x00}},
      {"P-09", "601: 2B 40 60 00 07 00 00 00", "581: 60 40 60 00 00 00 00 00", {0x6040, 0}, {0x07, 0x00}},
      {"P-10", "601: 2B 40 60 00 0F 00 00 00", "581: 60 40 60 00 00 00 00 00", {0x6040, 0}, {0x0F, 0x00}},
      {"P-11", "601: 2B 40 60 00 4F 00 00 00", "581: 60 40 60 00 00 00 00 00", {0x6040, 0}, {0x4F, 0x00}},
      {"P-12", "601: 2B 40 60 00 5F 00 00 00", "581:60 40 60 00 00 00 00 00", {0x6040, 0}, {0x5F, 0x00}},
      // §4.2.5 profile velocity (V-05's printed reply echoes 6081h; D-11 is the correct reply)
      {"V-02", "601: 2B 40 60 00 00 00 00 00", "581: 60 40 60 00 00 00 00 00", {0x6040, 0}, {0x00, 0x00}},
      {"V-03", "601: 23 83 60 00 64 00 00 00", "581: 60 83 60 00 00 00 00 00", {0x6083, 0}, {0x64, 0, 0, 0}},
      {"V-04", "601: 23 84 60 00 64 00 00 00", "581: 60 84 60 00 00 00 00 00", {0x6084, 0}, {0x64, 0, 0, 0}},
      {"D-11", "601: 23 FF 60 00 3C 00 00 00", "581: 60 FF 60 00 00 00 00 00", {0x60FF, 0}, {0x3C, 0, 0, 0}},
      {"V-06", "601: 2F 60 60 00 03 00 00 00", "581: 60 60 60 00 00 00 00 00", {0x6060, 0}, {0x03}},
      {"V-07", "601: 2B 40 60 00 06 00 00 00", "581: 60 40 60 00 00 00 00 00", {0x6040, 0}, {0x06, 0x00}},
      {"V-08", "601: 2B 40 60 00 07 00 00 00", "581: 60 40 60 00 00 00 00 00", {0x6040, 0}, {0x07, 0x00}},
      {"V-09", "601: 2B 40 60 00 0F 00 00 00", "581: 60 40 60 00 00 00 00 00", {0x6040, 0}, {0x0F, 0x00}},
      // §4.2.6 homing, as printed (H-03 writes 100, H-04 writes sub 00)
      {"H-02", "601: 2B 40 60 00 00 00 00 00", "581: 60 40 60 00 00 00 00 00", {0x6040, 0}, {0x00, 0x00}},
      {"H-03", "601: 2F 98 60 00 64 00 00 00", "581: 60 98 60 00 00 00 00 00", {0x6098, 0}, {0x64}},
      {"H-04", "601: 23 99 60 00 78 00 00 00", "581: 60 99 60 00 00 00 00 00", {0x6099, 0}, {0x78, 0, 0, 0}},
      {"H-05", "601: 23 99 60 01 3C 00 00 00", "581: 60 99 60 01 00 00 00 00", {0x6099, 1}, {0x3C, 0, 0, 0}},
      {"H-06", "601: 23 9A 60 00 64 00 00 00", "581: 60 9A 60 00 00 00 00 00", {0x609A, 0}, {0x64, 0, 0, 0}},
      {"H-07", "601: 2F 60 60 00 06 00 00 00", "581: 60 60 60 00 00 00 00 00", {0x6060, 0}, {0x06}},
      {"H-08", "601: 2B 40 60 00 06 00 00 00", "581: 60 40 60 00 00 00 00 00", {0x6040, 0}, {0x06, 0x00}},
      {"H-09", "601: 2B 40 60 00 07 00 00 00", "581: 60 40 60 00 00 00 00 00", {0x6040, 0}, {0x07, 0x00}},
      {"H-10", "601: 2B 40 60 00 0F 00 00 00", "581: 60 40 60 00 00 00 00 00", {0x6040, 0}, {0x0F, 0x00}},
      {"H-11", "601: 2B 40 60 00 1F 00 00 00", "581: 60 40 60 00 00 00 00 00", {0x6040, 0}, {0x1F, 0x00}},
      // Derived vectors (CiA 301 §7.2.4.3; not printed in the manual)
      {"D-02", "601: 23 7A 60 00 80 F3 FF FF", "581: 60 7A 60 00 00 00 00 00", {0x607A, 0}, {0x80, 0xF3, 0xFF, 0xFF}},
      {"D-03", "601: 23 81 60 00 78 00 00 00", "581: 60 81 60 00 00 00 00 00", {0x6081, 0}, {0x78, 0, 0, 0}},
      {"D-10", "601: 23 FF 60 00 C4 FF FF FF", "581: 60 FF 60 00 00 00 00 00", {0x60FF, 0}, {0xC4, 0xFF, 0xFF, 0xFF}},
      {"D-19", "601: 2B 17 10 00 E8 03 00 00", "581: 60 17 10 00 00 00 00 00", {0x1017, 0}, {0xE8, 0x03}},
      {"D-31", "601: 23 00 14 01 01 02 00 80", "581: 60 00 14 01 00 00 00 00", {0x1400, 1}, {0x01, 0x02, 0x00, 0x80}},
      {"D-32", "601: 2F 00 16 00 00 00 00 00", "581: 60 00 16 00 00 00 00 00", {0x1600, 0}, {0x00}},
      {"D-33", "601: 23 00 16 01 10 00 40 60", "581: 60 00 16 01 00 00 00 00", {0x1600, 1}, {0x10, 0x00, 0x40, 0x60}},
      {"D-34", "601: 23 00 16 02 20 00 7A 60", "581: 60 00 16 02 00 00 00 00", {0x1600, 2}, {0x20, 0x00, 0x7A, 0x60}},
      {"D-35", "601: 2F 00 16 00 02 00 00 00", "581: 60 00 16 00 00 00 00 00", {0x1600, 0}, {0x02}},
      {"D-36", "601: 2F 00 14 02 01 00 00 00", "581: 60 00 14 02 00 00 00 00", {0x1400, 2}, {0x01}},
      {"D-37", "601: 23 00 14 01 01 02 00 00", "581: 60 00 14 01 00 00 00 00", {0x1400, 1}, {0x01, 0x02, 0x00, 0x00}},
      {"D-50.1", "601: 2F 98 60 00 18 00 00 00", "581: 60 98 60 00 00 00 00 00", {0x6098, 0}, {0x18}},
      {"D-50.3", "601: 23 99 60 02 3C 00 00 00", "581: 60 99 60 02 00 00 00 00", {0x6099, 2}, {0x3C, 0, 0, 0}},
      {"D-53", "601: 2B 40 60 00 0F 01 00 00", "581: 60 40 60 00 00 00 00 00", {0x6040, 0}, {0x0F, 0x01}},
      {"D-55", "601: 2B 12 20 00 01 00 00 00", "581: 60 12 20 00 00 00 00 00", {0x2012, 0}, {0x01, 0x00}},
      {"D-57", "601: 2B 06 20 00 04 00 00 00", "581: 60 06 20 00 00 00 00 00", {0x2006, 0}, {0x04, 0x00}},
  };
}

TEST(SdoCodec, EveryManualAndDerivedExpeditedDownload) {
  for (const auto& v : manual_downloads()) {
    SCOPED_TRACE(v.id);
    const auto request = decode_sdo_request(payload(v.request));
    ASSERT_TRUE(request);
    const auto* initiate = std::get_if<SdoInitiateDownloadRequest>(&*request);
    ASSERT_NE(initiate, nullptr);
    EXPECT_EQ(initiate->object, v.object);
    EXPECT_TRUE(initiate->expedited);
    EXPECT_TRUE(initiate->size_indicated);
    EXPECT_EQ(std::vector<std::uint8_t>(initiate->data.view().begin(), initiate->data.view().end()), v.data);
    const auto data = *InlineBytes<kSdoExpeditedMax>::from(v.data);
    EXPECT_EQ(sdo_request_frame(1, SdoInitiateDownloadRequest{SdoInitiateData::expedited_data(v.object, data)}),
              frame(v.request));

    const auto reply = decode_sdo_response(payload(v.reply));
    ASSERT_TRUE(reply);
    EXPECT_EQ(*reply, SdoResponse{SdoInitiateDownloadResponse{v.object}});
    EXPECT_EQ(sdo_response_frame(1, SdoInitiateDownloadResponse{v.object}), frame(v.reply));
  }
}

TEST(SdoCodec, ManualVelocityReplyEchoesAnotherObject) {
  // V-05 as printed: the reply to a 60FFh write names 6081h. It decodes; a client must
  // notice the mismatch (see the SDO client tests).
  const auto reply = decode_sdo_response(payload("581: 60 81 60 00 00 00 00 00"));
  ASSERT_TRUE(reply);
  const SdoResponse expected = SdoInitiateDownloadResponse{ObjectAddress{0x6081, 0}};
  EXPECT_EQ(*reply, expected);
}

struct UploadVector {
  const char* id;
  const char* request;
  const char* reply;
  ObjectAddress object;
  std::vector<std::uint8_t> data;
};

TEST(SdoCodec, ExpeditedUploads) {
  const std::vector<UploadVector> vectors = {
      {"D-04", "601: 40 41 60 00 00 00 00 00", "581: 4B 41 60 00 37 02 00 00", {0x6041, 0}, {0x37, 0x02}},
      {"D-05", "601: 40 00 10 00 00 00 00 00", "581: 43 00 10 00 92 01 04 00", {0x1000, 0}, {0x92, 0x01, 0x04, 0x00}},
      {"D-06", "601: 40 18 10 01 00 00 00 00", "581: 43 18 10 01 22 03 00 00", {0x1018, 1}, {0x22, 0x03, 0x00, 0x00}},
      {"D-07", "601: 40 61 60 00 00 00 00 00", "581: 4F 61 60 00 01 00 00 00", {0x6061, 0}, {0x01}},
      {"D-08a", "601: 40 64 60 00 00 00 00 00", "581: 43 64 60 00 10 27 00 00", {0x6064, 0}, {0x10, 0x27, 0, 0}},
      {"D-08b", "601: 40 64 60 00 00 00 00 00", "581: 43 64 60 00 80 F3 FF FF", {0x6064, 0}, {0x80, 0xF3, 0xFF, 0xFF}},
      {"D-09", "601: 40 06 20 00 00 00 00 00", "581: 4B 06 20 00 0D 00 00 00", {0x2006, 0}, {0x0D, 0x00}},
      {"MC_HOME.2", "601: 40 61 60 00 00 00 00 00", "581: 4F 61 60 00 06 00 00 00", {0x6061, 0}, {0x06}},
      {"MC_STOP.3", "601: 40 6C 60 00 00 00 00 00", "581: 43 6C 60 00 00 00 00 00", {0x606C, 0}, {0, 0, 0, 0}},
  };
  for (const auto& v : vectors) {
    SCOPED_TRACE(v.id);
    EXPECT_EQ(decode_sdo_request(payload(v.request)), SdoRequest{SdoInitiateUploadRequest{v.object}});
    EXPECT_EQ(sdo_request_frame(1, SdoInitiateUploadRequest{v.object}), frame(v.request));
    const auto reply = decode_sdo_response(payload(v.reply));
    ASSERT_TRUE(reply);
    const auto* initiate = std::get_if<SdoInitiateUploadResponse>(&*reply);
    ASSERT_NE(initiate, nullptr);
    EXPECT_EQ(initiate->object, v.object);
    EXPECT_TRUE(initiate->expedited);
    EXPECT_EQ(std::vector<std::uint8_t>(initiate->data.view().begin(), initiate->data.view().end()), v.data);
    const auto data = *InlineBytes<kSdoExpeditedMax>::from(v.data);
    EXPECT_EQ(sdo_response_frame(1, SdoInitiateUploadResponse{SdoInitiateData::expedited_data(v.object, data)}),
              frame(v.reply));
  }
}

TEST(SdoCodec, ThreeByteExpeditedAndSizeNotIndicated) {
  // 0x27: 3 data bytes; 0x47 the matching upload reply (CiA 301 §7.2.4.3).
  const auto three = SdoInitiateData::expedited_data({0x2000, 0}, {1, 2, 3});
  EXPECT_EQ(sdo_request_frame(1, SdoInitiateDownloadRequest{three}), frame("601: 27 00 20 00 01 02 03 00"));
  EXPECT_EQ(sdo_response_frame(1, SdoInitiateUploadResponse{three}), frame("581: 47 00 20 00 01 02 03 00"));
  // 0x22: expedited without size: all four bytes are handed over, the object's type decides.
  const auto request = decode_sdo_request(payload("601: 22 40 60 00 0F 00 00 00"));
  ASSERT_TRUE(request);
  const auto& initiate = std::get<SdoInitiateDownloadRequest>(*request);
  EXPECT_TRUE(initiate.expedited);
  EXPECT_FALSE(initiate.size_indicated);
  EXPECT_EQ(initiate.data.size(), 4u);
}

struct AbortVector {
  const char* id;
  const char* reply;
  ObjectAddress object;
  SdoAbortCode code;
};

TEST(SdoCodec, AbortsWithTheirCodes) {
  const std::vector<AbortVector> vectors = {
      {"D-20", "581: 80 41 60 00 02 00 01 06", {0x6041, 0}, SdoAbortCode::kWriteOfReadOnly},
      {"D-21", "581: 80 5A 60 00 00 00 02 06", {0x605A, 0}, SdoAbortCode::kObjectDoesNotExist},
      {"D-22", "581: 80 99 60 03 11 00 09 06", {0x6099, 3}, SdoAbortCode::kSubindexDoesNotExist},
      {"D-23", "581: 80 99 60 00 02 00 01 06", {0x6099, 0}, SdoAbortCode::kWriteOfReadOnly},
      {"D-24", "581: 80 81 60 00 32 00 09 06", {0x6081, 0}, SdoAbortCode::kValueTooLow},
      {"D-25", "581: 80 40 60 00 10 00 07 06", {0x6040, 0}, SdoAbortCode::kLengthMismatch},
      {"D-31 refused", "581: 80 00 14 01 02 00 01 06", {0x1400, 1}, SdoAbortCode::kWriteOfReadOnly},
  };
  for (const auto& v : vectors) {
    SCOPED_TRACE(v.id);
    const SdoAbort abort{v.object, static_cast<std::uint32_t>(v.code)};
    EXPECT_EQ(sdo_response_frame(1, abort), frame(v.reply));
    EXPECT_EQ(decode_sdo_response(payload(v.reply)), SdoResponse{abort});
    // A client abort has the same layout on 600h + n.
    EXPECT_EQ(decode_sdo_request(payload(v.reply)), SdoRequest{abort});
    EXPECT_EQ(sdo_abort_error(abort.code), make_error_code(v.code));
    EXPECT_FALSE(description(v.code).empty());
  }
}

TEST(SdoCodec, SegmentedDownloadD26) {
  EXPECT_EQ(sdo_request_frame(1, SdoInitiateDownloadRequest{SdoInitiateData::segmented({0x6081, 0}, 4)}),
            frame("601: 21 81 60 00 04 00 00 00"));
  EXPECT_EQ(decode_sdo_request(payload("601: 21 81 60 00 04 00 00 00")),
            SdoRequest{SdoInitiateDownloadRequest{SdoInitiateData::segmented({0x6081, 0}, 4)}});
  // t = 0, n = 3, c = 1: four data bytes 78 00 00 00.
  const SdoDownloadSegmentRequest segment{{false, true, {0x78, 0x00, 0x00, 0x00}}};
  EXPECT_EQ(sdo_request_frame(1, segment), frame("601: 07 78 00 00 00 00 00 00"));
  EXPECT_EQ(decode_sdo_request(payload("601: 07 78 00 00 00 00 00 00")), SdoRequest{segment});
  EXPECT_EQ(sdo_response_frame(1, SdoDownloadSegmentResponse{false}), frame("581: 20 00 00 00 00 00 00 00"));
  EXPECT_EQ(sdo_response_frame(1, SdoDownloadSegmentResponse{true}), frame("581: 30 00 00 00 00 00 00 00"));
  EXPECT_EQ(decode_sdo_response(payload("581: 30 00 00 00 00 00 00 00")),
            SdoResponse{SdoDownloadSegmentResponse{true}});
}

TEST(SdoCodec, SegmentedUploadsD27AndD28) {
  // D-27: 1000h answered segmented.
  EXPECT_EQ(sdo_response_frame(1, SdoInitiateUploadResponse{SdoInitiateData::segmented({0x1000, 0}, 4)}),
            frame("581: 41 00 10 00 04 00 00 00"));
  EXPECT_EQ(sdo_request_frame(1, SdoUploadSegmentRequest{false}), frame("601: 60 00 00 00 00 00 00 00"));
  const SdoUploadSegmentResponse d27{{false, true, {0x92, 0x01, 0x04, 0x00}}};
  EXPECT_EQ(sdo_response_frame(1, d27), frame("581: 07 92 01 04 00 00 00 00"));
  EXPECT_EQ(decode_sdo_response(payload("581: 07 92 01 04 00 00 00 00")), SdoResponse{d27});

  // D-28: "UC57 drive" in two segments.
  EXPECT_EQ(decode_sdo_response(payload("581: 41 08 10 00 0A 00 00 00")),
            SdoResponse{SdoInitiateUploadResponse{SdoInitiateData::segmented({0x1008, 0}, 10)}});
  const SdoUploadSegmentResponse first{{false, false, {'U', 'C', '5', '7', ' ', 'd', 'r'}}};
  const SdoUploadSegmentResponse second{{true, true, {'i', 'v', 'e'}}};
  EXPECT_EQ(sdo_response_frame(1, first), frame("581: 00 55 43 35 37 20 64 72"));
  EXPECT_EQ(sdo_response_frame(1, second), frame("581: 19 69 76 65 00 00 00 00"));
  EXPECT_EQ(decode_sdo_response(payload("581: 19 69 76 65 00 00 00 00")), SdoResponse{second});
  EXPECT_EQ(sdo_request_frame(1, SdoUploadSegmentRequest{true}), frame("601: 70 00 00 00 00 00 00 00"));
  EXPECT_EQ(decode_sdo_request(payload("601: 70 00 00 00 00 00 00 00")), SdoRequest{SdoUploadSegmentRequest{true}});
}

TEST(SdoCodec, RejectsShortFramesTrailingBytesAndBlockTransfer) {
  EXPECT_FALSE(decode_sdo_request(payload("601: 2B 40 60 00 0F 00 00")));  // 7 bytes
  EXPECT_FALSE(decode_sdo_request(payload("601:")));
  EXPECT_FALSE(decode_sdo_response(payload("581: 60 40 60 00")));
  const std::vector<std::uint8_t> nine = {0x60, 0x40, 0x60, 0x00, 0, 0, 0, 0, 0};
  EXPECT_FALSE(decode_sdo_response(nine));
  EXPECT_FALSE(decode_sdo_request(nine));
  EXPECT_FALSE(decode_sdo_request(payload("601: C6 00 10 00 00 00 00 00")));   // block download
  EXPECT_FALSE(decode_sdo_request(payload("601: A0 00 10 00 00 00 00 00")));   // block upload
  EXPECT_FALSE(decode_sdo_request(payload("601: E0 00 10 00 00 00 00 00")));   // ccs 7
  EXPECT_FALSE(decode_sdo_response(payload("581: A4 00 10 00 00 00 00 00")));  // block download
  EXPECT_FALSE(decode_sdo_response(payload("581: C4 00 10 00 00 00 00 00")));  // block upload
}

TEST(SdoErrors, CategoriesAndWireCodes) {
  const std::error_code timeout = SdoAbortCode::kTimeout;
  EXPECT_EQ(timeout.category().name(), std::string("canopen-sdo"));
  EXPECT_NE(timeout.message().find("05040000"), std::string::npos);
  EXPECT_EQ(to_abort_code(timeout), 0x05040000u);
  EXPECT_EQ(to_abort_code(CanopenError::kCancelled), 0x08000000u);
  // A manufacturer-specific code survives the round trip (all 32 bits).
  EXPECT_EQ(to_abort_code(sdo_abort_error(0xFFFF1234u)), 0xFFFF1234u);
  EXPECT_NE(sdo_abort_error(0xFFFF1234u).message().find("FFFF1234"), std::string::npos);
  const std::error_code cancelled = CanopenError::kCancelled;
  EXPECT_EQ(cancelled.category().name(), std::string("canopen"));
  EXPECT_EQ(cancelled.message(), "request cancelled");
}

}  // namespace
}  // namespace motion::canopen
