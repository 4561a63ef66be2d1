// Instruction strings: every syntax example of the manuals (EN/CN §1.6, §6.1, §12.3) and the range
// rules.
#include <gtest/gtest.h>

#include "motion/uim242/instruction.hpp"

namespace motion::uim242 {
namespace {

Instruction set(Mnemonic m, std::int64_t v) { return Instruction{m, false, v, false}; }
Instruction bare(Mnemonic m) { return Instruction{m, false, std::nullopt, false}; }
Instruction hex_set(Mnemonic m, std::int64_t v) { return Instruction{m, false, v, true}; }

void expect_parses(std::string_view text, const Instruction& expected) {
  SCOPED_TRACE(text);
  const auto parsed = parse_instruction(text);
  ASSERT_TRUE(parsed.ok()) << parsed.error().message();
  EXPECT_EQ(*parsed, expected);
}

void expect_error(std::string_view text, ErrorCode code) {
  SCOPED_TRACE(text);
  const auto parsed = parse_instruction(text);
  ASSERT_FALSE(parsed.ok());
  EXPECT_EQ(parsed.error(), make_error_code(code));
}

// Strip the trailing ';' the splitter removes.
std::string_view chunk(std::string_view with_semicolon) { return with_semicolon.substr(0, with_semicolon.size() - 1); }

TEST(InstructionSyntax, FillerBetweenMnemonicAndValueEN16) {
  for (const char* text : {"SPD = 1000;", "SPD: 1000;", "SPD 1000;", "SPD1000;", "SPD %?&%* 1000;"}) {
    expect_parses(chunk(text), set(Mnemonic::kSPD, 1000));
  }
}

TEST(InstructionSyntax, CaseAndFillerCN16) {
  for (const char* text : {"SPD=1000;", "Spd:1000;", "SPD 1000;", "sPD1000;", "SPD%?&?*1000;"}) {
    expect_parses(chunk(text), set(Mnemonic::kSPD, 1000));
  }
}

TEST(InstructionSyntax, SignGivesDirectionEN61CN61) {
  expect_parses("SPD=+1000", set(Mnemonic::kSPD, 1000));
  expect_parses("SPD= -1000", set(Mnemonic::kSPD, -1000));
  expect_parses("SPD +1000", set(Mnemonic::kSPD, 1000));
  expect_parses("SPD -1000", set(Mnemonic::kSPD, -1000));
  expect_parses("QEC - 200000", set(Mnemonic::kQEC, -200000));  // EN/CN §9.0
}

TEST(InstructionSyntax, LeavePositionModeEN61) {
  expect_parses("STP=0", set(Mnemonic::kSTP, 0));
  expect_parses("STP 0", set(Mnemonic::kSTP, 0));
}

TEST(InstructionSyntax, NullInstructionAndEnableTimerQuery) {
  expect_parses("", bare(Mnemonic::kNull));
  expect_parses("  ", bare(Mnemonic::kNull));
  for (const char* text : {"ENAXFFFF", "ENAxFFFF"}) {
    SCOPED_TRACE(text);
    const auto parsed = parse_instruction(text);
    ASSERT_TRUE(parsed.ok());
    EXPECT_TRUE(is_enable_timer_query(*parsed));
  }
  EXPECT_FALSE(is_enable_timer_query(set(Mnemonic::kENA, 1000)));
}

TEST(InstructionSyntax, HexValuesAreLowByteFirstEN17CN17) {
  expect_parses("MCF34611", set(Mnemonic::kMCF, 0x8733));
  expect_parses("MCFx3387", hex_set(Mnemonic::kMCF, 0x8733));    // CN #17
  expect_parses("MCFx 34 12", hex_set(Mnemonic::kMCF, 0x1234));  // EN/CN #17
  expect_parses("ICFx 34 12", hex_set(Mnemonic::kICF, 0x1234));  // EN/CN #13
  expect_parses("MCF x0180", hex_set(Mnemonic::kMCF, 0x8001));   // CN §8.11
  expect_parses("MCFx0800", hex_set(Mnemonic::kMCF, 0x0008));    // CN §10.5
  // EN writes `MCFx8733;` big-endian (EN #17, against EN's own §12.1 rule): CN's byte rule reads it
  // as 0x3387.
  expect_parses("MCFx8733", hex_set(Mnemonic::kMCF, 0x3387));
}

TEST(InstructionSyntax, ScfRegisterWritesEN8CN8) {
  const auto scf = [](std::string_view text) {
    const auto parsed = parse_instruction(text);
    EXPECT_TRUE(parsed.ok()) << text;
    return parsed.ok() ? scf_write(*parsed) : std::nullopt;
  };
  EXPECT_EQ(scf("SCFx 34 12 00"), (ScfWrite{SensorRegister::kS12CON, 0x1234}));  // #34
  EXPECT_EQ(scf("SCF 8352"), (ScfWrite{SensorRegister::kS12CON, 0x020A}));       // §8.10
  EXPECT_EQ(scf("SCFx0A0200"), (ScfWrite{SensorRegister::kS12CON, 0x020A}));     // CN §8.10
  EXPECT_EQ(scf("SCF 672"), (ScfWrite{SensorRegister::kS12CON, 0x002A}));        // §8.11
  EXPECT_EQ(scf("SCF x2A0000"), (ScfWrite{SensorRegister::kS12CON, 0x002A}));
  EXPECT_EQ(scf("SCF 52419"), (ScfWrite{SensorRegister::kATCONH, 3276}));
  EXPECT_EQ(scf("SCF xCC0C03"), (ScfWrite{SensorRegister::kATCONH, 3276}));
  EXPECT_EQ(scf("SCF 7858"), (ScfWrite{SensorRegister::kATCONL, 491}));
  EXPECT_EQ(scf("SCF xEB0102"), (ScfWrite{SensorRegister::kATCONL, 491}));
  EXPECT_EQ(scf("SCF 40961"), (ScfWrite{SensorRegister::kS34CON, 0x0A00}));  // §10.5
  EXPECT_EQ(scf("SCF x000A01"), (ScfWrite{SensorRegister::kS34CON, 0x0A00}));
  EXPECT_EQ(make_scf(ScfWrite{SensorRegister::kS12CON, 0x020A}), set(Mnemonic::kSCF, 8352));
}

TEST(InstructionSyntax, EnglishLegacyHexExamplesAreRejected) {
  // Odd digit count (§12.1) and missing IDX byte: the EN big-endian forms of §8.10/§8.11/§10.5.
  expect_error("SCF x2A0", ErrorCode::kSyntaxError);
  expect_error("SCF xCCC3", ErrorCode::kSyntaxError);
  expect_error("SCFx 20A0", ErrorCode::kSyntaxError);
  expect_error("MCFx001", ErrorCode::kSyntaxError);
  expect_error("MCFx10A", ErrorCode::kSyntaxError);
}

TEST(InstructionSyntax, StgSamplingModeEN40CN41) {
  const auto parsed = parse_instruction("STGx C8 00 00");
  ASSERT_TRUE(parsed.ok());
  EXPECT_EQ(stg_write(*parsed), (StgWrite{0, 200}));
  EXPECT_EQ(make_stg(StgWrite{0, 200}), *parsed);
}

TEST(InstructionSyntax, EncoderExamplesEN9CN9) {
  expect_parses("MCF 1792", set(Mnemonic::kMCF, 1792));
  expect_parses("STP 500", set(Mnemonic::kSTP, 500));
  expect_parses("QER 500", set(Mnemonic::kQER, 500));
  expect_parses("SQT 150", set(Mnemonic::kSQT, 150));
  expect_parses("SPD100", set(Mnemonic::kSPD, 100));
  expect_parses("STP200", set(Mnemonic::kSTP, 200));
}

TEST(InstructionSyntax, GlobalAndGatewayForms) {
  expect_parses("gSPD 500", Instruction{Mnemonic::kSPD, true, 500, false});
  expect_parses("gOFF", Instruction{Mnemonic::kOFF, true, std::nullopt, false});
  expect_parses("gOFFLINE", Instruction{Mnemonic::kOFF, true, std::nullopt, false});
  expect_parses("gENABLE", Instruction{Mnemonic::kENA, true, std::nullopt, false});
  expect_parses("gDOUT 1", Instruction{Mnemonic::kDOU, true, 1, false});
  expect_parses("gREG", Instruction{Mnemonic::kREG, true, std::nullopt, false});
  expect_parses("ADR 6", set(Mnemonic::kADR, 6));
  expect_parses("SETADR = 7", set(Mnemonic::kSET, 7));
  expect_parses("ABC", bare(Mnemonic::kABC));
  expect_error("REG", ErrorCode::kSyntaxError);
  expect_error("gSQT 5", ErrorCode::kSyntaxError);
}

TEST(InstructionErrors, ValueErrorsCN6) {
  expect_error("CUR 81", ErrorCode::kValueError);
  expect_error("MCS 3", ErrorCode::kValueError);
  expect_error("STO 8", ErrorCode::kValueError);
  expect_error("DOU 2", ErrorCode::kValueError);
  expect_error("SPD 65536", ErrorCode::kValueError);
  expect_error("ACR -1", ErrorCode::kValueError);
  expect_error("ADR 126", ErrorCode::kValueError);
  expect_error("SCF 7860", ErrorCode::kValueError);  // suffix 4
  expect_error("STGx C8 00 03", ErrorCode::kValueError);
}

TEST(InstructionErrors, SyntaxErrors) {
  expect_error("XYZ 5", ErrorCode::kSyntaxError);
  expect_error("SPD 10 00", ErrorCode::kSyntaxError);  // η has no other characters inside
  expect_error("SPD 1000x", ErrorCode::kSyntaxError);
  expect_error("SPDx 10", ErrorCode::kSyntaxError);  // no hex form for signed values (EN/CN §12.3)
  expect_error("CUR", ErrorCode::kSyntaxError);      // no query form
  expect_error("FBK 5", ErrorCode::kSyntaxError);
  expect_error("SPD -", ErrorCode::kSyntaxError);
  expect_error("SPD %?&%*abc 1000", ErrorCode::kSyntaxError);
  expect_error("SPD = = = = = 100000", ErrorCode::kSyntaxError);  // 21 characters with the ';'
  expect_error("SPD \xC3\xA9 1", ErrorCode::kSyntaxError);        // extended ASCII
}

TEST(InstructionEncode, DecimalHexGlobalAndSelect) {
  EXPECT_EQ(encode(set(Mnemonic::kSPD, -1000)).value(), "SPD -1000;");
  EXPECT_EQ(encode(bare(Mnemonic::kFBK)).value(), "FBK;");
  EXPECT_EQ(encode(bare(Mnemonic::kNull)).value(), ";");
  EXPECT_EQ(encode(hex_set(Mnemonic::kMCF, 0x1234)).value(), "MCFx 34 12;");
  EXPECT_EQ(encode(make_stg(StgWrite{0, 200})).value(), "STGx C8 00 00;");
  EXPECT_EQ(encode_global(Mnemonic::kSPD, 500).value(), "gSPD 500;");
  EXPECT_EQ(encode_select(5).value(), "ADR 5;");
  EXPECT_EQ(encode_set(Mnemonic::kSTP, -2147483647).value(), "STP -2147483647;");
  EXPECT_EQ(encode_set(Mnemonic::kCUR, 81).error(), make_error_code(CodecErrc::kValueOutOfRange));
  EXPECT_EQ(encode_bare(Mnemonic::kCUR).error(), make_error_code(CodecErrc::kValueRequired));
  EXPECT_EQ(encode_set(Mnemonic::kFBK, 1).error(), make_error_code(CodecErrc::kValueNotAllowed));
  EXPECT_EQ(encode(hex_set(Mnemonic::kSPD, 1)).error(), make_error_code(CodecErrc::kHexNotAllowed));
  EXPECT_EQ(encode_global(Mnemonic::kMCF, 1).error(), make_error_code(CodecErrc::kNotGlobal));
}

TEST(InstructionEncode, EveryTableEntryRoundTripsThroughTheParser) {
  for (const auto& s : instruction_table()) {
    SCOPED_TRACE(s.text);
    std::vector<Instruction> forms;
    if (s.mnemonic == Mnemonic::kREG) {
      forms.push_back(Instruction{s.mnemonic, true, std::nullopt, false});
    } else {
      if (s.bare_form) forms.push_back(bare(s.mnemonic));
      if (s.decimal_form) {
        forms.push_back(set(s.mnemonic, s.min));
        forms.push_back(set(s.mnemonic, s.max));
      }
      if (s.global_form && s.decimal_form) forms.push_back(Instruction{s.mnemonic, true, s.max, false});
    }
    for (const auto& form : forms) {
      const auto text = encode(form);
      ASSERT_TRUE(text.ok()) << text.error().message();
      EXPECT_LE(text->size(), kMaxInstructionChars);
      expect_parses(chunk(*text), form);
    }
  }
}

TEST(InstructionErrors, ErrorCategoryNamesTheCode) {
  EXPECT_STREQ(error_category().name(), "uim242");
  EXPECT_EQ(make_error_code(ErrorCode::kValueError).message(), "instruction value error (EE 66)");
  EXPECT_EQ(make_error_code(ErrorCode::kSyntaxError).value(), 0x65);
}

// ---- Splitter -----------------------------------------------------------------------------

std::vector<InstructionChunk> split_bytewise(InstructionSplitter& s, std::string_view text) {
  std::vector<InstructionChunk> all;
  for (const char c : text) {
    for (auto& chunk_out : s.push(std::string_view(&c, 1))) all.push_back(std::move(chunk_out));
  }
  return all;
}

std::size_t acked(const std::vector<InstructionChunk>& chunks) {
  std::size_t n = 0;
  for (const auto& c : chunks) n += c.silent ? 0 : 1;
  return n;
}

TEST(InstructionSplitter, FourInstructionsFourAcksEN23) {
  InstructionSplitter s;
  const auto chunks = s.push(std::string_view{"CUR 20; MCS 16; SPD 5000; ENA;"});
  ASSERT_EQ(chunks.size(), 4u);
  EXPECT_EQ(acked(chunks), 4u);
  EXPECT_EQ(parse_instruction(chunks[1].text).value(), set(Mnemonic::kMCS, 16));
}

TEST(InstructionSplitter, MacroYieldsOneAckEN23) {
  InstructionSplitter s;
  const auto chunks = split_bytewise(s, "{CUR 20; MCS 16; SPD 5000; ENA; };");
  ASSERT_EQ(chunks.size(), 5u);
  EXPECT_EQ(acked(chunks), 1u);
  EXPECT_EQ(parse_instruction(chunks.back().text).value(), bare(Mnemonic::kNull));
  EXPECT_FALSE(s.in_macro());
}

TEST(InstructionSplitter, MacroWithoutTrailingSemicolonYieldsNoAckButEnds) {
  InstructionSplitter s;
  auto chunks = s.push(std::string_view{"{CUR 20; MCS 16; SPD 5000; ENA; }"});
  EXPECT_EQ(acked(chunks), 0u);
  EXPECT_FALSE(s.in_macro());
  chunks = s.push(std::string_view{"FBK;"});
  ASSERT_EQ(chunks.size(), 1u);
  EXPECT_FALSE(chunks[0].silent);
  EXPECT_EQ(parse_instruction(chunks[0].text).value(), bare(Mnemonic::kFBK));
}

TEST(InstructionSplitter, OversizeRunBecomesOneSyntaxError) {
  InstructionSplitter s;
  const std::string junk(200, 'Z');
  auto chunks = s.push(std::string_view{junk});
  EXPECT_TRUE(chunks.empty());
  chunks = s.push(std::string_view{"; FBK;"});
  ASSERT_EQ(chunks.size(), 2u);
  EXPECT_TRUE(chunks[0].oversize);
  EXPECT_EQ(parse_instruction(chunks[1].text).value(), bare(Mnemonic::kFBK));
}

}  // namespace
}  // namespace motion::uim242
