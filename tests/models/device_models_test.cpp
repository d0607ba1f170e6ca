// The built-in device models against their manuals: the manuals' examples decode to the values
// the manuals state, the models' rules fire on frames that break them and stay silent on legal
// ones, and every register of the manuals' tables is in the YAML.
#include <cctype>
#include <fstream>
#include <sstream>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "decoder/models/model_interpreter.hpp"
#include "decoder/models/model_yaml.hpp"
#include "decoder/models/register_meaning.hpp"
#include "decoder/protocol/checksum.hpp"
#include "plugins/models/builtin_models.hpp"
#include "tools/modtap/model_catalog.hpp"

namespace modtap {
namespace {

using ::testing::ElementsAre;
using ::testing::HasSubstr;
using ::testing::IsEmpty;
using ::testing::SizeIs;

std::vector<uint8_t> hex(const std::string& text) {
  std::vector<uint8_t> bytes;
  std::istringstream in(text);
  std::string pair;
  while (in >> pair) bytes.push_back(static_cast<uint8_t>(std::stoul(pair, nullptr, 16)));
  return bytes;
}

// An RTU ADU from slave + PDU; the CRC is computed, so the examples state only what they mean.
std::vector<uint8_t> rtu(const std::string& body) {
  auto adu = hex(body);
  const uint16_t crc = crc16(adu);
  adu.push_back(static_cast<uint8_t>(crc & 0xFF));
  adu.push_back(static_cast<uint8_t>(crc >> 8));
  return adu;
}

// A frame as the matcher hands it on; `adu` must outlive it.
Frame frame_of(const std::vector<uint8_t>& adu, Role role, Mode mode = Mode::rtu) {
  Frame f;
  f.adu = adu;
  f.raw = adu;
  f.role = role;
  f.mode = mode;
  f.check_ok = true;
  return f;
}

class Models : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    catalog_ = new tools::ModelCatalog;
    catalog_->load_builtin();
  }
  static void TearDownTestSuite() { delete catalog_; }

  const DeviceModel& model(const char* name) {
    const DeviceModel* found = catalog_->find(name);
    EXPECT_NE(found, nullptr) << name;
    return *found;
  }

  Frame frame(const std::vector<uint8_t>& adu, Role role, Mode mode = Mode::rtu) {
    return frame_of(adu, role, mode);
  }

  Meaning request(const char* name, const std::vector<uint8_t>& adu, Mode mode = Mode::rtu) {
    return interpret(model(name), frame(adu, Role::request, mode));
  }

  // The response read with its request's PDU, as the matcher hands it on.
  Meaning response(const char* name, const std::vector<uint8_t>& request_adu,
                   const std::vector<uint8_t>& response_adu) {
    Frame f = frame(response_adu, Role::response);
    f.request_pdu = std::span<const uint8_t>(request_adu).subspan(1, request_adu.size() - 3);
    return interpret(model(name), f);
  }

  static std::vector<RuleKind> kinds(const Meaning& meaning) {
    std::vector<RuleKind> out;
    for (const auto& f : meaning.findings) out.push_back(f.kind);
    return out;
  }

  static tools::ModelCatalog* catalog_;
};

tools::ModelCatalog* Models::catalog_ = nullptr;

// --- The manuals' examples ---------------------------------------------------------------

TEST_F(Models, Nta5000ReadOf2523HGivesTheFrequencyCommand) {
  // 4.1: the request (with the corrected CRC 7EH CCH) and the response 07D0H as printed.
  const auto req = hex("01 03 25 23 00 01 7E CC");
  const auto rsp = hex("01 03 02 07 D0 BB E8");
  const Meaning m = response("nta5000", req, rsp);
  ASSERT_EQ(m.registers.size(), 1u);
  EXPECT_EQ(m.registers[0].address, 0x2523);
  EXPECT_EQ(m.registers[0].name, "frequency_command_monitor");
  EXPECT_EQ(m.registers[0].raw, 0x07D0u);
  EXPECT_DOUBLE_EQ(m.registers[0].value, 20.00);
  EXPECT_EQ(m.registers[0].unit, "Hz");
  EXPECT_THAT(m.findings, IsEmpty());
}

// A text line or a pcapng comment shows only what the model names: the stage then leaves the
// other words out, and a model that names nothing reads nothing.
TEST_F(Models, WordsTheModelDoesNotNameAreLeftOutWhenAsked) {
  const auto req = rtu("01 03 25 2F 00 03");  // 252FH (reserved), 2530H (reserved), 2531H
  const auto rsp = rtu("01 03 06 00 01 00 02 00 03");
  for (const bool listed : {true, false}) {
    Frame f = frame(rsp, Role::response);
    f.request_pdu = std::span<const uint8_t>(req).subspan(1, req.size() - 3);
    Meaning nta5000, generic;
    nta5000.lists_unnamed = generic.lists_unnamed = listed;
    interpret(model("nta5000"), f, nta5000);
    interpret(model("generic"), f, generic);
    std::vector<std::string> names;
    for (const auto& reg : nta5000.registers) names.emplace_back(reg.name);
    const std::vector<std::string> named = {"reserved_252F", "reserved_2530"};
    std::vector<std::string> all = named;
    all.emplace_back("");
    EXPECT_EQ(names, listed ? all : named);
    EXPECT_EQ(generic.registers.size(), listed ? 3u : 0u);
  }
}

TEST_F(Models, Nta5000WriteOf1770HTo2502HIs60Hz) {
  const auto adu = hex("01 06 25 02 17 70 2D 12");  // 4.3, RTU
  const Meaning m = request("nta5000", adu);
  ASSERT_EQ(m.registers.size(), 1u);
  EXPECT_EQ(m.registers[0].name, "frequency_command");
  EXPECT_DOUBLE_EQ(m.registers[0].value, 60.00);
  EXPECT_EQ(m.registers[0].decimals, 2);
  EXPECT_THAT(m.findings, IsEmpty());
  // The echo shows the same register.
  const Meaning echo = response("nta5000", adu, adu);
  ASSERT_EQ(echo.registers.size(), 1u);
  EXPECT_DOUBLE_EQ(echo.registers[0].value, 60.00);
}

TEST_F(Models, Nta5000MultiWriteIsForwardRunAt60Hz) {
  const Meaning m = request("nta5000", hex("01 10 25 01 00 02 04 00 01 17 70 CB 26"));  // 4.4
  ASSERT_EQ(m.registers.size(), 2u);
  EXPECT_EQ(m.registers[0].name, "operation_signal");
  EXPECT_EQ(m.registers[0].text, "Run, Forward");
  EXPECT_EQ(m.registers[1].name, "frequency_command");
  EXPECT_DOUBLE_EQ(m.registers[1].value, 60.00);
  EXPECT_THAT(m.findings, IsEmpty());
}

TEST_F(Models, Nta5000ExceptionIsExplainedWithTheVendorsMeaning) {
  const auto req = rtu("01 06 25 02 17 70");
  const Meaning m = response("nta5000", req, hex("01 86 52 C3 9D"));  // 4.3, fault response
  ASSERT_THAT(kinds(m), ElementsAre(RuleKind::exception));
  EXPECT_EQ(m.findings[0].text, "vendor exception 52H: Address error (nta5000)");
}

// A code in no table: said as what it is, for the bus with no model and for a drive's.
TEST_F(Models, AnExceptionCodeInNoTableSaysWhoseTablesWereRead) {
  const auto req = rtu("01 06 25 02 17 70");
  const auto answer = rtu("01 86 5a");
  const Meaning generic = response("generic", req, answer);
  ASSERT_THAT(kinds(generic), ElementsAre(RuleKind::exception));
  EXPECT_EQ(generic.findings[0].text,
            "exception 5AH is not a standard Modbus exception code (no model for slave 1)");
  const Meaning drive = response("nta5000", req, answer);
  ASSERT_THAT(kinds(drive), ElementsAre(RuleKind::exception));
  EXPECT_EQ(drive.findings[0].text,
            "exception 5AH is in neither the standard's table nor nta5000's");
}

TEST_F(Models, Nta5000StatusBitsAndFaultCodeHaveTheirNames) {
  const auto req = rtu("01 03 25 20 00 03");
  const Meaning m = response("nta5000", req, rtu("01 03 06 00 0B 00 0D 00 41"));
  ASSERT_EQ(m.registers.size(), 3u);
  EXPECT_EQ(m.registers[0].text, "Run, Reverse, Unready, Abnormal");
  EXPECT_EQ(m.registers[1].text, "OL1 (motor over load)");
  EXPECT_EQ(m.registers[2].text, "S1, RELAY1");
}

// N3 0121H, "Fault description": 0 is "The inverter is normal", any other value the fault the
// drive reports (22: OL2, inverter over load). Named as a device fault where the drive says it.
TEST_F(Models, AFaultTheDriveReportsIsADeviceFault) {
  const auto read = rtu("02 03 01 21 00 01");
  const Meaning tripped = response("n3", read, rtu("02 03 02 00 16"));
  ASSERT_THAT(kinds(tripped), ElementsAre(RuleKind::device_fault));
  EXPECT_EQ(tripped.findings[0].text,
            "the device reports a fault: OL2 (inverter over load) (fault = 22)");
  EXPECT_THAT(response("n3", read, rtu("02 03 02 00 00")).findings, IsEmpty());
  // NTA5000 2521H alike; a write to it is the master's, no report of the drive's.
  EXPECT_THAT(kinds(response("nta5000", rtu("01 03 25 21 00 01"), rtu("01 03 02 00 0B"))),
              ElementsAre(RuleKind::device_fault));
  EXPECT_THAT(kinds(request("n3", rtu("02 06 01 21 00 16"))),
              ::testing::Not(::testing::Contains(RuleKind::device_fault)));
}

TEST_F(Models, Nta5000ChineseVariantDiffersWhereItsManualDoes) {
  const auto req = rtu("01 03 25 21 00 01");
  const auto rsp = rtu("01 03 02 00 28");  // fault 40
  EXPECT_THAT(response("nta5000-cn", req, rsp).registers[0].text, HasSubstr("OVSP"));
  // The English table stops at 39: 40 is not one of its named values, but a fault still.
  EXPECT_THAT(kinds(response("nta5000", req, rsp)),
              ElementsAre(RuleKind::device_fault, RuleKind::not_in_enum));
  EXPECT_EQ(response("nta5000", req, rtu("01 03 02 00 0B")).registers[0].text, "Reserved");
  EXPECT_THAT(response("nta5000-cn", req, rtu("01 03 02 00 0B")).registers[0].text,
              HasSubstr("OL3"));
  const auto torque = rtu("01 03 25 29 00 01");
  EXPECT_EQ(response("nta5000-cn", torque, rtu("01 03 02 00 10")).registers[0].name,
            "output_torque");
  EXPECT_TRUE(
      response("nta5000", torque, rtu("01 03 02 00 10")).registers[0].name.find("reserved") == 0);
  EXPECT_THAT(kinds(request("nta5000-cn", rtu("21 03 25 20 00 01"))),
              ElementsAre(RuleKind::station_out_of_range));
  EXPECT_THAT(request("nta5000", rtu("21 03 25 20 00 01")).findings, IsEmpty());
}

TEST_F(Models, Nta5000ParametersFollowTheGroupRule) {
  const auto req = rtu("01 03 0A 0B 00 01");  // F10.11, the manual's own example of GGnnH
  const Meaning m = response("nta5000", req, rtu("01 03 02 00 05"));
  ASSERT_EQ(m.registers.size(), 1u);
  EXPECT_EQ(m.registers[0].name, "F10.11");
  // F00 has 15 parameters: 000FH is no parameter, and decodes as a raw value.
  const Meaning beyond = response("nta5000", rtu("01 03 00 0F 00 01"), rtu("01 03 02 12 34"));
  EXPECT_EQ(beyond.registers[0].name, "");
  EXPECT_EQ(beyond.registers[0].raw, 0x1234u);
}

TEST_F(Models, N3ExamplesDecodeToTheManualsValues) {
  const Meaning write = request("n3", hex("01 06 01 02 17 70 27 E2"));  // 4.5
  ASSERT_EQ(write.registers.size(), 1u);
  EXPECT_EQ(write.registers[0].name, "frequency_command");
  EXPECT_DOUBLE_EQ(write.registers[0].value, 60.00);
  // 4.3 with the corrected response CRC (B6H 50H).
  const Meaning read = response("n3", hex("01 03 01 23 00 01 74 3C"), hex("01 03 02 17 70 B6 50"));
  ASSERT_EQ(read.registers.size(), 1u);
  EXPECT_EQ(read.registers[0].address, 0x0123);
  EXPECT_DOUBLE_EQ(read.registers[0].value, 60.00);
  const Meaning multi = request("n3", hex("01 10 01 01 00 02 04 00 01 17 70 60 27"));  // 4.6
  ASSERT_EQ(multi.registers.size(), 2u);
  EXPECT_EQ(multi.registers[0].text, "Run, Forward");
  EXPECT_DOUBLE_EQ(multi.registers[1].value, 60.00);
}

TEST_F(Models, N3ParameterTableMapsRegistersOutOfOrder) {
  const auto req = rtu("01 03 00 07 00 03");
  const Meaning m = response("n3", req, rtu("01 03 06 00 01 00 02 00 03"));
  ASSERT_EQ(m.registers.size(), 3u);
  EXPECT_EQ(m.registers[0].name, "A007");
  EXPECT_EQ(m.registers[1].name, "B012");
  EXPECT_EQ(m.registers[2].name, "B000");
  EXPECT_THAT(kinds(request("n3", rtu("01 06 00 32 00 01"))),
              ElementsAre(RuleKind::reserved_write));  // 0032H is '~' in the table
}

TEST_F(Models, Gd20ReadOf0004HAnd0005HGivesP0004AndP0005) {
  // 7.3.1.1: the request and the response with 1388H and 0000H.
  const Meaning m =
      response("gd20", hex("01 03 00 04 00 02 85 CA"), hex("01 03 04 13 88 00 00 7E 9D"));
  ASSERT_EQ(m.registers.size(), 2u);
  EXPECT_EQ(m.registers[0].name, "P00.04");
  EXPECT_EQ(m.registers[0].raw, 5000u);
  EXPECT_EQ(m.registers[1].name, "P00.05");
  EXPECT_EQ(m.registers[1].raw, 0u);
}

TEST_F(Models, Gd20WriteOf0001HTo2000HIsForwardRunning) {
  const Meaning m = request("gd20", rtu("03 06 20 00 00 01"));  // 7.5.2 example 1
  ASSERT_EQ(m.registers.size(), 1u);
  EXPECT_EQ(m.registers[0].name, "control_command");
  EXPECT_EQ(m.registers[0].text, "Forward running");
  EXPECT_THAT(m.findings, IsEmpty());
}

TEST_F(Models, Gd20OtherExamplesDecodeToTheManualsValues) {
  // 7.5.1: state word 1 reads 0003H, "the inverter stops".
  EXPECT_EQ(response("gd20", rtu("01 03 21 00 00 01"), rtu("01 03 02 00 03")).registers[0].text,
            "Stop");
  // 7.5.2 example 2: 2710H to P00.03 is 100 Hz.
  const Meaning max = request("gd20", rtu("03 06 00 03 27 10"));
  EXPECT_EQ(max.registers[0].name, "P00.03");
  EXPECT_DOUBLE_EQ(max.registers[0].value, 100.00);
  // 7.5.3 example 1: run forward at 10 Hz.
  const Meaning run = request("gd20", rtu("01 10 20 00 00 02 04 00 01 03 E8"));
  ASSERT_EQ(run.registers.size(), 2u);
  EXPECT_EQ(run.registers[0].text, "Forward running");
  EXPECT_DOUBLE_EQ(run.registers[1].value, 10.00);
  // 7.5.3 example 2: ACC time 10 s, DEC time 20 s.
  const Meaning times = request("gd20", rtu("01 10 00 0B 00 02 04 00 64 00 C8"));
  EXPECT_DOUBLE_EQ(times.registers[0].value, 10.0);
  EXPECT_EQ(times.registers[0].unit, "s");
  EXPECT_DOUBLE_EQ(times.registers[1].value, 20.0);
  // 7.4.4: P00.01 = 3 is out of range, and the slave answers 86H 04H "operation failed".
  const auto bad = rtu("01 06 00 01 00 03");
  EXPECT_THAT(kinds(request("gd20", bad)),
              ElementsAre(RuleKind::out_of_range, RuleKind::not_in_enum));
  const Meaning refused = response("gd20", bad, rtu("01 86 04"));
  ASSERT_THAT(kinds(refused), ElementsAre(RuleKind::exception));
  EXPECT_THAT(refused.findings[0].text, HasSubstr("Operation failed"));
}

// --- Rule findings -----------------------------------------------------------------------

TEST_F(Models, WritesToReservedOrReadOnlyRegistersAreFound) {
  EXPECT_THAT(kinds(request("nta5000", rtu("01 06 25 03 00 01"))),
              ElementsAre(RuleKind::reserved_write));
  EXPECT_THAT(kinds(request("nta5000", rtu("01 06 25 24 00 01"))),
              ElementsAre(RuleKind::read_only_write));
  EXPECT_THAT(kinds(request("gd20", rtu("01 06 30 00 00 01"))),
              ElementsAre(RuleKind::read_only_write));
  EXPECT_THAT(request("nta5000", rtu("01 06 25 01 00 01")).findings, IsEmpty());
}

TEST_F(Models, ReadsOfWriteOnlyRegistersAndAliasesAreFound) {
  const Meaning alias_read = request("gd20", rtu("01 03 80 07 00 01"));
  ASSERT_THAT(kinds(alias_read), ElementsAre(RuleKind::write_only_read));
  EXPECT_THAT(alias_read.findings[0].text, HasSubstr("P00.07"));
  EXPECT_THAT(kinds(request("gd20", rtu("01 03 20 02 00 01"))),
              ElementsAre(RuleKind::write_only_read));  // 2002H PID reference: "W" in both
  // Writing the alias is what it is for: RAM only, and silent.
  const Meaning alias_write = request("gd20", rtu("01 06 80 07 00 05"));
  EXPECT_THAT(alias_write.findings, IsEmpty());
  EXPECT_EQ(alias_write.registers[0].name, "P00.07 (RAM)");
  EXPECT_EQ(alias_write.registers[0].label, "RAM only, not stored in EEPROM");
}

// GD20 7.4.1: "Changing the high bit of the function code form 0 to 1 ... P00.07 ... set the
// address to 8007H": the alias is of parameters (PGG.nn) only. The control word 2000H, the
// identifying code 2103H and the running frequency 3000H with the high bit set are no
// registers of the drive.
TEST_F(Models, Gd20RamAliasReachesParametersOnly) {
  for (const char* write : {"01 06 A0 00 00 01", "01 06 A1 03 00 01", "01 06 B0 00 00 01"}) {
    const Meaning meaning = request("gd20", rtu(write));
    EXPECT_THAT(kinds(meaning), ElementsAre(RuleKind::unmapped_register)) << write;
    for (const RegisterValue& v : meaning.registers) EXPECT_EQ(v.name, "") << write;
  }
  EXPECT_EQ(request("gd20", rtu("01 06 8A 01 00 05")).registers[0].name, "P10.01 (RAM)");
}

TEST_F(Models, MoreWordsThanTheModelAllowsAreFoundPerMode) {
  EXPECT_THAT(request("nta5000", rtu("01 03 03 00 00 25")).findings, IsEmpty());  // 37
  EXPECT_THAT(kinds(request("nta5000", rtu("01 03 03 00 00 26"))),
              ElementsAre(RuleKind::too_many_words));  // 38
  const auto read18 = hex("01 03 03 00 00 12 00");     // ASCII: 17 allowed
  EXPECT_THAT(kinds(request("nta5000", read18, Mode::ascii)),
              ElementsAre(RuleKind::too_many_words));
  EXPECT_THAT(request("nta5000", hex("01 03 03 00 00 11 00"), Mode::ascii).findings, IsEmpty());
  EXPECT_THAT(kinds(request("gd20", rtu("01 03 00 00 00 11"))),
              ElementsAre(RuleKind::too_many_words));  // 17 > 16
  EXPECT_THAT(request("gd20", rtu("01 03 00 00 00 10")).findings, IsEmpty());
  // Beyond the standard's 125 is the function-code table's quantity-out-of-spec, not the model's to
  // repeat.
  EXPECT_THAT(request("generic", rtu("01 03 00 00 00 7E")).findings, IsEmpty());
  EXPECT_THAT(kinds(request("nta5000", rtu("01 03 25 00 00 7E"))),
              ElementsAre(RuleKind::too_many_words));  // NTA5000's own 37 still counts
}

TEST_F(Models, AccessesAcrossParameterGroupsAreFound) {
  const Meaning m = request("nta5000", rtu("01 03 01 16 00 02"));  // F01.22 and F01.23
  EXPECT_THAT(m.findings, IsEmpty());
  EXPECT_THAT(kinds(request("nta5000", rtu("01 03 01 FF 00 02"))),
              ElementsAre(RuleKind::crosses_group));
  EXPECT_THAT(request("gd20", rtu("01 03 00 FF 00 02")).findings, IsEmpty());  // no such rule
}

TEST_F(Models, StationsOutsideTheModelsRangeAreFound) {
  EXPECT_THAT(kinds(request("nta5000", rtu("41 03 25 20 00 01"))),
              ElementsAre(RuleKind::station_out_of_range));
  EXPECT_THAT(request("nta5000", rtu("40 03 25 20 00 01")).findings, IsEmpty());
  EXPECT_THAT(request("n3", rtu("FE 03 01 20 00 01")).findings, IsEmpty());
  EXPECT_THAT(kinds(request("n3", rtu("FF 03 01 20 00 01"))),
              ElementsAre(RuleKind::reserved_address));
  EXPECT_THAT(kinds(request("gd20", rtu("F8 03 21 00 00 01"))),
              ElementsAre(RuleKind::reserved_address));
  EXPECT_THAT(request("gd20", rtu("00 06 20 00 00 05")).findings, IsEmpty());  // broadcast
}

// --- What the manuals say that the models first left out ----------------------------------

TEST_F(Models, ReservedAddressesAreFoundUnlessTheModelAllowsThem) {
  // N3 1.3: "Max to No. 254 (FEH)"; Modbus reserves 248-255 (Serial Line 2.2).
  EXPECT_THAT(request("n3", rtu("FE 03 01 20 00 01")).findings, IsEmpty());
  const auto req = rtu("FE 03 01 20 00 01");
  const Meaning generic_request = request("generic", req);
  ASSERT_THAT(kinds(generic_request), ElementsAre(RuleKind::reserved_address));
  EXPECT_THAT(generic_request.findings[0].text, HasSubstr("address 254 is reserved"));
  EXPECT_THAT(kinds(response("generic", req, rtu("FE 03 02 00 05"))),
              ElementsAre(RuleKind::reserved_address));  // said of the response too
}

TEST_F(Models, Nta5000ChineseExceptionTextsComeFromTheChineseChapter) {
  // 001, 3.错误代码: "53 校验码错误" (check code error), "54 数据设定错误" (data setting error);
  // the English chapter says "53 Data Amount Error", "54 DATA Over Range".
  const auto req = rtu("01 03 03 00 00 28");
  auto text_of = [&](const char* model_name, const char* exception) {
    const Meaning m = response(model_name, req, rtu(exception));
    return m.findings.empty() ? std::string() : std::string(m.findings[0].text);
  };
  EXPECT_THAT(text_of("nta5000-cn", "01 83 53"), HasSubstr("Check code error (校验码错误)"));
  EXPECT_THAT(text_of("nta5000-cn", "01 83 54"), HasSubstr("Data setting error (数据设定错误)"));
  EXPECT_THAT(text_of("nta5000", "01 83 53"), HasSubstr("Data amount error"));
  EXPECT_THAT(text_of("nta5000", "01 83 54"), HasSubstr("Data over range"));
}

TEST_F(Models, AnalogInputsAreScaledAsTheManualsState) {
  // 000: "252CH TM2 AI1 input value (100% / 10V)"; 001: "（1000 / 10V）"; N3: "(1024 / 10V)".
  const auto ai1 = rtu("01 03 25 2C 00 01");
  const Meaning english = response("nta5000", ai1, rtu("01 03 02 01 F4"));  // 500 counts
  ASSERT_EQ(english.registers.size(), 1u);
  EXPECT_DOUBLE_EQ(english.registers[0].value, 50.0);
  EXPECT_EQ(english.registers[0].unit, "%");
  const Meaning chinese = response("nta5000-cn", ai1, rtu("01 03 02 01 F4"));
  EXPECT_DOUBLE_EQ(chinese.registers[0].value, 5.0);
  EXPECT_EQ(chinese.registers[0].unit, "V");
  const Meaning n3 = response("n3", rtu("01 03 01 2C 00 03"), rtu("01 03 06 04 00 02 00 00 00"));
  ASSERT_EQ(n3.registers.size(), 3u);
  EXPECT_DOUBLE_EQ(n3.registers[0].value, 10.0);  // 1024 counts
  EXPECT_DOUBLE_EQ(n3.registers[1].value, 5.0);   // 512
  EXPECT_EQ(n3.registers[2].unit, "V");
}

TEST_F(Models, Nta5000PidInputIsSignedAsTheChineseChapterSays) {
  // 001: "252BH PID输入量（100% / 最大输出频率，10/1% 附符号）": sign attached, in both models.
  for (const char* name : {"nta5000", "nta5000-cn"}) {
    const Meaning m = response(name, rtu("01 03 25 2B 00 01"), rtu("01 03 02 FF 9C"));
    ASSERT_EQ(m.registers.size(), 1u) << name;
    EXPECT_DOUBLE_EQ(m.registers[0].value, -10.0) << name;
  }
}

TEST_F(Models, Gd20ControlWordsMayBeReadBack) {
  // 7.4.2 says "W" for 2000H and 2001H; the table beside the 7.5 examples says "W/R".
  EXPECT_THAT(request("gd20", rtu("01 03 20 00 00 02")).findings, IsEmpty());
}

TEST_F(Models, AReadRunningPastAGroupsLastParameterCrossesTheGroup) {
  // 000: "Can only continuous read the address of the same Group"; F03.48 (0330H) is F03's last.
  const Meaning past_end = request("nta5000", rtu("01 03 03 2F 00 04"));  // F03.47 .. 0332H
  ASSERT_THAT(kinds(past_end), ElementsAre(RuleKind::crosses_group));
  EXPECT_THAT(past_end.findings[0].text, HasSubstr("runs past 0330H"));
  EXPECT_THAT(request("nta5000", rtu("01 03 03 2F 00 02")).findings, IsEmpty());  // to F03.48
}

TEST_F(Models, N3SetsItsOwnTimeoutAndRetries) {
  // N3 2.3: "TIME-OUT (400ms) & RETRY (max. : 2 times)".
  const DeviceModel& n3 = model("n3");
  ASSERT_TRUE(n3.response_timeout_ns.has_value());
  EXPECT_EQ(*n3.response_timeout_ns, 400'000'000);
  EXPECT_EQ(n3.retries, 2);
  EXPECT_FALSE(model("generic").response_timeout_ns.has_value());
  ModelChoice choice;
  choice.bus = &model("generic");
  choice.by_slave[2] = &n3;
  const SlaveTimeouts timeouts = model_timeouts(choice);
  EXPECT_EQ(timeouts[2], 400'000'000);
  EXPECT_EQ(std::count(timeouts.begin(), timeouts.end(), 0), 255);
  // A third retry is more than an N3 master makes.
  const auto adu = rtu("02 03 01 20 00 01");
  Frame third = frame(adu, Role::request);
  third.retries = 3;
  EXPECT_THAT(kinds(interpret(n3, third)), ElementsAre(RuleKind::too_many_retries));
  third.retries = 2;
  EXPECT_THAT(interpret(n3, third).findings, IsEmpty());
}

TEST_F(Models, Nta5000FaultyFc03ExampleDecodesAsWhatItIs) {
  // 000 prints the FC03 request as 01 03 A0 23 00 01 with CRC 57H C0H: a good CRC over the
  // wrong address. It is a read of A023H, which is in no table of the manual.
  const auto req = hex("01 03 A0 23 00 01 57 C0");
  const Meaning asked = request("nta5000", req);
  ASSERT_THAT(kinds(asked), ElementsAre(RuleKind::unmapped_register));
  EXPECT_THAT(asked.findings[0].text, HasSubstr("A023H"));
  const Meaning m = response("nta5000", req, rtu("01 03 02 07 D0"));
  ASSERT_EQ(m.registers.size(), 1u);
  EXPECT_EQ(m.registers[0].address, 0xA023);
  EXPECT_EQ(m.registers[0].name, "");
  // The generic model has no register map: nothing is unmapped there.
  EXPECT_THAT(request("generic", req).findings, IsEmpty());
}

TEST_F(Models, ValuesOutsideRangeOrEnumAreFound) {
  EXPECT_THAT(kinds(request("gd20", rtu("01 06 20 00 00 09"))), ElementsAre(RuleKind::not_in_enum));
  EXPECT_THAT(kinds(request("gd20", rtu("01 06 20 04 0B B9"))),  // 300.1 %
              ElementsAre(RuleKind::out_of_range));
  const Meaning negative = request("gd20", rtu("01 06 20 04 F4 48"));  // -300.0 %, signed
  EXPECT_DOUBLE_EQ(negative.registers[0].value, -300.0);
  EXPECT_THAT(negative.findings, IsEmpty());
}

// GD20 300AH, Input IO: "000~1FF". A range the manual gives is said with both its ends; one
// whose other end is a parameter (3001H, "0.00Hz~P00.03") with the end it has.
TEST_F(Models, ARangeIsSaidAsTheManualGivesIt) {
  const Meaning input_io = response("gd20", rtu("01 03 30 0A 00 01"), rtu("01 03 02 02 00"));
  ASSERT_THAT(kinds(input_io), ElementsAre(RuleKind::out_of_range));
  EXPECT_EQ(input_io.findings[0].text, "input_io_1 = 512 is outside 0..511");
  EXPECT_THAT(kinds(request("gd20", rtu("01 06 20 0B 00 10"))),  // 200BH: 0x00~0x0F
              ElementsAre(RuleKind::out_of_range));
  const DeviceModel one_ended = parse_model(
      "model: one-ended\n"
      "registers:\n"
      "  - {address: 0x3001, name: setting_frequency, type: s16, scale: 0.01, min: 0}\n",
      "one-ended.yaml");
  const Meaning below = interpret(one_ended, frame(rtu("01 06 30 01 FF 9C"), Role::request));
  ASSERT_THAT(kinds(below), ElementsAre(RuleKind::out_of_range));
  EXPECT_EQ(below.findings[0].text, "setting_frequency = -1.00 is below its minimum 0");
}

TEST_F(Models, FactoryGroupIsClosed) {
  EXPECT_THAT(kinds(request("gd20", rtu("01 03 1D 00 00 02"))),
              ElementsAre(RuleKind::closed_group));
}

TEST_F(Models, GenericModelNamesNothingAndExplainsStandardExceptions) {
  const Meaning m = response("generic", rtu("01 03 00 00 00 01"), rtu("01 03 02 00 2A"));
  ASSERT_EQ(m.registers.size(), 1u);
  EXPECT_EQ(m.registers[0].name, "");
  EXPECT_DOUBLE_EQ(m.registers[0].value, 42);
  const Meaning e = response("generic", rtu("01 03 00 00 00 01"), rtu("01 83 02"));
  EXPECT_EQ(e.findings[0].text, "exception 02H: Illegal data address (generic)");
}

// --- Identification ----------------------------------------------------------------------

// A finding's text lives as long as its frame's callback; the recorder keeps a copy.
struct KeptFinding {
  RuleKind kind;
  std::string text;
};

class Recorder final : public RecordSink {
 public:
  void on_frame(const Frame& frame) override {
    models.push_back(frame.meaning ? frame.meaning->model->name : "");
    auto& kept = findings.emplace_back();
    if (frame.meaning)
      for (const RuleFinding& f : frame.meaning->findings)
        kept.push_back({f.kind, std::string(f.text)});
  }
  void on_noise(const Noise&) override {}
  void on_timeout(const Timeout&) override {}
  std::vector<std::string> models;
  std::vector<std::vector<KeptFinding>> findings;
};

TEST_F(Models, ASlaveReadingGd20sIdentifyingCodeIsDecodedAsGd20) {
  Recorder out;
  ModelChoice choice;
  choice.bus = &model("generic");
  ModelInterpreter interpreter(catalog_->all(), choice, ClockQuality::per_byte, out);
  const auto req = rtu("05 03 21 03 00 01");
  const auto rsp = rtu("05 03 02 01 06");
  Frame q = frame(req, Role::request);
  Frame r = frame(rsp, Role::response);
  r.request_pdu = std::span<const uint8_t>(req).subspan(1, 5);
  interpreter.on_frame(q);
  interpreter.on_frame(r);
  interpreter.on_frame(q);
  EXPECT_THAT(out.models, ElementsAre("generic", "gd20", "gd20"));
  ASSERT_EQ(out.findings[1].size(), 1u);
  EXPECT_EQ(out.findings[1][0].kind, RuleKind::identified);
  EXPECT_THAT(out.findings[1][0].text, HasSubstr("slave 5 identifies as gd20"));
}

TEST_F(Models, AnIdentificationDoesNotOverrideTheUsersChoice) {
  Recorder out;
  ModelChoice choice;
  choice.bus = &model("generic");
  choice.by_slave[5] = &model("n3");
  ModelInterpreter interpreter(catalog_->all(), choice, ClockQuality::per_byte, out);
  const auto req = rtu("05 03 21 03 00 01");
  const auto rsp = rtu("05 03 02 01 06");
  Frame r = frame(rsp, Role::response);
  r.request_pdu = std::span<const uint8_t>(req).subspan(1, 5);
  interpreter.on_frame(r);
  EXPECT_THAT(out.models, ElementsAre("n3"));
  EXPECT_THAT(out.findings[0][0].text, HasSubstr("but is decoded as n3"));
}

// The NTA5000 and N3 manuals ask for 10 ms between a command and its reply; an answer sooner,
// timed by a clock per byte, is not what such a drive does. GD20's manual sets no such time.
TEST_F(Models, AnAnswerSoonerThanTheManualsTurnaroundIsEarly) {
  const auto req = rtu("01 03 25 20 00 01");
  const auto rsp = rtu("01 03 02 00 00");
  auto early_findings = [&](const char* name, int64_t latency_ms, ClockQuality clock) {
    Recorder out;
    ModelChoice choice;
    choice.bus = &model(name);
    ModelInterpreter interpreter(catalog_->all(), choice, clock, out);
    Frame r = frame(rsp, Role::response);
    r.request_pdu = std::span<const uint8_t>(req).subspan(1, 5);
    r.latency_ns = latency_ms * 1'000'000;
    interpreter.on_frame(r);
    std::vector<std::string> texts;
    for (const KeptFinding& f : out.findings[0])
      if (f.kind == RuleKind::early_response) texts.push_back(f.text);
    return texts;
  };
  EXPECT_THAT(early_findings("nta5000", 4, ClockQuality::per_byte),
              ElementsAre("answered 4.000 ms after the request; nta5000 answers no sooner than "
                          "10 ms"));
  EXPECT_THAT(early_findings("nta5000-cn", 4, ClockQuality::per_byte), SizeIs(1));
  EXPECT_THAT(early_findings("n3", 9, ClockQuality::per_byte), SizeIs(1));
  EXPECT_THAT(early_findings("n3", 10, ClockQuality::per_byte), IsEmpty());
  EXPECT_THAT(early_findings("nta5000", 4, ClockQuality::per_chunk), IsEmpty());
  EXPECT_THAT(early_findings("gd20", 1, ClockQuality::per_byte), IsEmpty());
}

// --- Every register of the manuals' tables -------------------------------------------------

struct ListedRegister {
  uint16_t address;
  std::string name;
};

std::vector<ListedRegister> manual_list(const std::string& file) {
  std::ifstream in(std::string(MODTAP_TEST_DATA) + "/models/" + file);
  EXPECT_TRUE(in) << file;
  std::vector<ListedRegister> out;
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream fields(line);
    std::string address, name;
    fields >> address >> name;
    out.push_back({static_cast<uint16_t>(std::stoul(address, nullptr, 16)), name});
  }
  return out;
}

void expect_all_listed(const DeviceModel& model, const std::vector<ListedRegister>& list) {
  for (const auto& listed : list) {
    const RegisterLookup found = find_register(model, Table::holding, listed.address);
    ASSERT_NE(found.def(), nullptr) << model.name << " lacks " << std::hex << listed.address;
    if (!listed.name.empty()) {
      EXPECT_EQ(found.def()->name, listed.name) << listed.address;
    }
  }
}

TEST_F(Models, EveryRegisterInTheNta5000ManualIsInTheModel) {
  const auto list = manual_list("nta5000.list");
  EXPECT_EQ(list.size(), 10u + 17u + 285u);  // 2500H-2509H, 2520H-2530H, F00.00-F13.47
  expect_all_listed(model("nta5000"), list);
  expect_all_listed(model("nta5000-cn"), list);
}

TEST_F(Models, EveryRegisterInTheN3ManualIsInTheModel) {
  const auto list = manual_list("n3.list");
  EXPECT_EQ(list.size(), 2u + 29u + 15u + 174u);  // command, reserved, monitor, parameters
  expect_all_listed(model("n3"), list);
}

TEST_F(Models, EveryRegisterInTheGd20ManualIsInTheModel) {
  const auto list = manual_list("gd20.list");
  EXPECT_EQ(list.size(), 15u + 4u + 23u + 1u);  // 2000H-200EH, 2100H-2103H, 3000H-3016H, 5000H
  expect_all_listed(model("gd20"), list);
}

// --- Every fault code and exception text of the manuals -------------------------------------

struct ListedCode {
  uint32_t code;
  std::string name;  // the manual's short name, "normal" or "unused"; or an exception's name
};

std::vector<ListedCode> code_list(const std::string& file, int base) {
  std::ifstream in(std::string(MODTAP_TEST_DATA) + "/models/" + file);
  EXPECT_TRUE(in) << file;
  std::vector<ListedCode> out;
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    const auto space = line.find(' ');
    out.push_back({static_cast<uint32_t>(std::stoul(line.substr(0, space), nullptr, base)),
                   line.substr(space + 1)});
  }
  return out;
}

std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

// The model's text names what the manual names: its mnemonic, "normal", or an unused row.
void expect_names(const std::string& text, const std::string& listed, uint32_t code) {
  if (listed == "unused") {
    EXPECT_THAT(lower(text), testing::ContainsRegex("unused|not used|reserved")) << code;
  } else {
    EXPECT_THAT(lower(text), HasSubstr(lower(listed))) << code;
  }
}

void expect_faults(const DeviceModel& m, uint16_t address, size_t count) {
  const auto list = code_list(m.name + "-faults.list", 10);
  ASSERT_EQ(list.size(), count);
  const auto& faults = *m.registers.at({Table::holding, address}).values;
  EXPECT_EQ(faults.size(), list.size()) << m.name;
  for (const auto& [code, name] : list) {
    ASSERT_TRUE(faults.contains(code)) << m.name << " lacks fault " << code;
    expect_names(faults.at(code), name, code);
  }
}

void expect_exceptions(const DeviceModel& m, size_t count) {
  const auto list = code_list(m.name + "-exceptions.list", 16);
  ASSERT_EQ(list.size(), count);
  EXPECT_TRUE(m.vendor_exceptions);
  EXPECT_EQ(m.exceptions.size(), list.size()) << m.name;
  for (const auto& [code, name] : list) {
    ASSERT_TRUE(m.exceptions.contains(static_cast<uint8_t>(code))) << m.name << " " << code;
    EXPECT_THAT(lower(m.exceptions.at(static_cast<uint8_t>(code))), HasSubstr(lower(name)));
  }
}

TEST_F(Models, EveryFaultCodeInTheManualsIsInTheModels) {
  expect_faults(model("nta5000"), 0x2521, 40);     // 000 2521H: 00-39
  expect_faults(model("nta5000-cn"), 0x2521, 41);  // 001 2521H 异常内容: 00-40, OVSP added
  expect_faults(model("n3"), 0x0121, 46);          // 002 121H: 00-45
}

TEST_F(Models, EveryExceptionTextInTheManualsIsInTheModels) {
  expect_exceptions(model("nta5000"), 5);  // 000 "3 Error Code": 51H-55H
  expect_exceptions(model("nta5000-cn"), 5);  // 001 "3.错误代码", its own texts (53H 校验码错误)
  expect_exceptions(model("n3"), 5);          // 002 "3.Error code"
  expect_exceptions(model("gd20"), 9);        // 004 7.4.4: the standard numbers, the vendor's names
}

// --- Bad dictionaries ----------------------------------------------------------------------

TEST(ModelFiles, ProblemsNameTheFileAndLine) {
  const std::string yaml =
      "model: broken\n"
      "registers:\n"
      "  - {address: 0x2502, name: f, scale: fast}\n"
      "  - {address: 0x2503, nmae: g}\n"
      "  - {address: 0x2504, name: h, enum: nowhere}\n";
  try {
    parse_model(yaml, "broken.yaml");
    FAIL() << "no error";
  } catch (const ModelError& e) {
    EXPECT_THAT(e.problems(), ::testing::Contains(HasSubstr("broken.yaml:3: expected a number")));
    EXPECT_THAT(e.problems(), ::testing::Contains(HasSubstr("broken.yaml:4: unknown key 'nmae'")));
    EXPECT_THAT(e.problems(), ::testing::Contains(HasSubstr("broken.yaml:5: no enum named")));
  }
}

TEST(ModelFiles, YamlSyntaxErrorsNameTheLine) {
  EXPECT_THROW(
      {
        try {
          parse_model("model: x\nregisters: [\n  {address: 1\n", "syntax.yaml");
        } catch (const ModelError& e) {
          EXPECT_THAT(e.what(), HasSubstr("syntax.yaml:"));
          throw;
        }
      },
      ModelError);
  EXPECT_THROW(parse_model("- just\n- a list\n", "list.yaml"), ModelError);
  // A list where a name belongs: the line of the offending node, not a crash.
  try {
    parse_model("model: x\nenums:\n  ? [1, 2]\n  : {1: a}\n", "kinds.yaml");
    FAIL() << "no error";
  } catch (const ModelError& e) {
    EXPECT_THAT(e.what(), HasSubstr("kinds.yaml:3:"));
  }
  EXPECT_THROW(parse_model("", "empty.yaml"), ModelError);
}

TEST(ModelFiles, AKeyWrittenTwiceIsAProblem) {
  try {
    parse_model("model: x\nregisters:\n  - address: 1\n    name: a\n    name: b\n", "twice.yaml");
    FAIL() << "no error";
  } catch (const ModelError& e) {
    EXPECT_THAT(e.problems(),
                ::testing::ElementsAre(HasSubstr("twice.yaml:5: 'name' is written twice")));
  }
}

// A register whose minimum is above its maximum, or an address defined twice in one file, is
// a mistake in the model: refused with the file and line.
TEST(ModelFiles, ALimitUpsideDownOrARegisterTwiceIsAProblem) {
  try {
    parse_model(
        "model: x\n"
        "registers:\n"
        "  - {address: 1, name: a, min: 10, max: 5}\n"
        "  - {address: 2, name: b}\n"
        "  - {address: 2, name: c}\n",
        "limits.yaml");
    FAIL() << "no error";
  } catch (const ModelError& e) {
    EXPECT_THAT(e.problems(),
                ::testing::ElementsAre(HasSubstr("limits.yaml:3: min 10 is above max 5"),
                                       HasSubstr("limits.yaml:5: holding 0002H is defined twice")));
  }
}

// What a model file says against itself is refused with its line, not taken one way: stations
// upside down, closed groups not a list, a register's values named twice, a run of registers
// ('to') that is not reserved.
TEST(ModelFiles, ContradictionsAreProblems) {
  struct Case {
    const char* yaml;
    const char* problem;
  };
  const Case cases[] = {
      {"model: x\nstations: [32, 1]\n", "x.yaml:2: stations [32, 1]: the first is above the last"},
      {"model: x\ngroups:\n  prefix: P\n  closed: 29\n",
       "x.yaml:4: closed must be a list of groups"},
      {"model: x\nenums:\n  on_off: {0: off, 1: on}\nregisters:\n"
       "  - {address: 1, name: a, enum: on_off, values: {0: no, 1: yes}}\n",
       "x.yaml:5: 'enum' and 'values' both name the values"},
      {"model: x\nregisters:\n  - {address: 1, to: 4, name: a, reserved: false}\n",
       "x.yaml:3: 'to' is for runs of reserved registers"},
  };
  for (const Case& c : cases) {
    try {
      parse_model(c.yaml, "x.yaml");
      ADD_FAILURE() << "no error for " << c.yaml;
    } catch (const ModelError& e) {
      EXPECT_THAT(e.problems(), ::testing::Contains(HasSubstr(c.problem))) << c.yaml;
    }
  }
}

TEST(ModelFiles, FlagsAreYamlsWordsForTrueAndFalse) {
  const auto reserved = [](const std::string& word) {
    const DeviceModel model = parse_model(
        "model: x\nregisters:\n  - {address: 1, name: a, reserved: " + word + "}\n", "f.yaml");
    return model.registers.at({Table::holding, 1}).reserved;
  };
  EXPECT_TRUE(reserved("true"));
  EXPECT_TRUE(reserved("yes"));
  EXPECT_TRUE(reserved("On"));
  EXPECT_FALSE(reserved("false"));
  EXPECT_FALSE(reserved("no"));
  EXPECT_THROW(reserved("maybe"), ModelError);
  EXPECT_THROW(reserved("[true]"), ModelError);
}

// Value types that the built-in models do not use, on a model of their own.
TEST(ModelTypes, MultiWordStringBcdAndOffsetValuesDecode) {
  const DeviceModel model = parse_model(
      "model: types\n"
      "registers:\n"
      "  - {address: 0, name: energy, type: u32, unit: kWh}\n"
      "  - {address: 2, name: counter, type: u32, order: low_first}\n"
      "  - {address: 4, name: delta, type: s32, scale: 0.1}\n"
      "  - {address: 6, name: flow, type: f32, unit: m3/h}\n"
      "  - {address: 8, name: serial, type: string, words: 3}\n"
      "  - {address: 11, name: version, type: bcd}\n"
      "  - {address: 12, name: temperature, type: s16, scale: 0.1, offset: -40, unit: C}\n"
      "  - {address: 13, name: blob, type: raw}\n",
      "types.yaml");
  const std::vector<uint16_t> words = {0x0001, 0x86A0,          // 100000
                                       0x86A0, 0x0001,          // 100000, low word first
                                       0xFFFF, 0xFF9C,          // -100 -> -10.0
                                       0x4148, 0x0000,          // 12.5f
                                       0x4142, 0x4344, 0x4500,  // "ABCDE"
                                       0x1234,                  // BCD 1234
                                       0x0258,                  // 600 * 0.1 - 40 = 20.0
                                       0xBEEF};
  Meaning meaning;
  decode_registers(model, Table::holding, 0, words, meaning);
  const std::vector<RegisterValue>& out = meaning.registers;
  ASSERT_EQ(out.size(), 8u);
  EXPECT_EQ(out[0].raw, 100000u);
  EXPECT_DOUBLE_EQ(out[0].value, 100000);
  EXPECT_DOUBLE_EQ(out[1].value, 100000);
  EXPECT_DOUBLE_EQ(out[2].value, -10.0);
  EXPECT_DOUBLE_EQ(out[3].value, 12.5);
  EXPECT_EQ(out[4].text, "ABCDE");
  EXPECT_DOUBLE_EQ(out[5].value, 1234);
  EXPECT_DOUBLE_EQ(out[6].value, 20.0);
  EXPECT_EQ(out[7].address, 13);
  EXPECT_DOUBLE_EQ(out[7].value, 0xBEEF);
}

// A float shows the digits it holds, whatever its scale: 12.53 A is not 13, nor 12.529999...
TEST(ModelTypes, AFloatShowsItsOwnDigitsNotTheScales) {
  const DeviceModel model = parse_model(
      "model: floats\n"
      "registers:\n"
      "  - {address: 0, name: current, type: f32, unit: A}\n"
      "  - {address: 2, name: power_factor, type: f32}\n"
      "  - {address: 4, name: power, type: f32, scale: 0.1, unit: kW}\n"
      "  - {address: 6, name: setpoint, type: f32, order: low_first}\n"
      "  - {address: 8, name: leakage, type: f32, unit: A}\n"
      "  - {address: 10, name: count, type: u16, scale: 0.01}\n",
      "floats.yaml");
  const std::vector<uint16_t> words = {0x4148, 0x7AE1,  // 12.53f
                                       0x3F73, 0xB646,  // 0.952f
                                       0x449C, 0xA000,  // 1253.0f x 0.1
                                       0x0000, 0xBF00,  // -0.5f, low word first
                                       0x38FB, 0xA882,  // 0.00012f
                                       0x04D2};         // 1234 x 0.01
  Meaning meaning;
  decode_registers(model, Table::holding, 0, words, meaning);
  std::vector<std::string> shown;
  for (const RegisterValue& reg : meaning.registers) {
    fmt::memory_buffer out;
    append_number(out, reg.value, reg.decimals);
    shown.push_back(fmt::to_string(out));
  }
  EXPECT_EQ(shown,
            (std::vector<std::string>{"12.53", "0.952", "125.3", "-0.5", "0.00012", "12.34"}));
}

// An inverter's energy and running-time counters span four registers.
TEST(ModelTypes, SixtyFourBitValuesSpanFourRegistersInEitherOrder) {
  const DeviceModel model = parse_model(
      "model: inverter\n"
      "registers:\n"
      "  - {address: 0, name: energy, type: u64, scale: 0.001, unit: kWh}\n"
      "  - {address: 4, name: balance, type: s64, order: low_first, unit: Wh}\n"
      "  - {address: 8, name: after, type: u16}\n",
      "inverter.yaml");
  EXPECT_EQ(model.registers.at({Table::holding, 0}).words, 4);
  const std::vector<uint16_t> words = {0x0000, 0x0001, 0x0000, 0x0000,  // 2^32
                                       0xFFFE, 0xFFFF, 0xFFFF, 0xFFFF,  // -2, low word first
                                       0x002A};
  Meaning meaning;
  decode_registers(model, Table::holding, 0, words, meaning);
  const std::vector<RegisterValue>& out = meaning.registers;
  ASSERT_EQ(out.size(), 3u);
  EXPECT_EQ(out[0].raw, uint64_t{1} << 32);
  EXPECT_DOUBLE_EQ(out[0].value, 4294967.296);
  EXPECT_EQ(out[0].decimals, 3);
  EXPECT_EQ(out[1].raw, ~uint64_t{1});
  EXPECT_DOUBLE_EQ(out[1].value, -2);
  EXPECT_EQ(out[2].address, 8);
  EXPECT_DOUBLE_EQ(out[2].value, 42);
  for (const char* type : {"u16, words: 5", "u32, words: 4", "s64, words: 2"})
    EXPECT_THROW(
        parse_model(
            fmt::format("model: x\nregisters:\n  - {{address: 0, name: a, type: {}}}\n", type),
            "x.yaml"),
        ModelError)
        << type;
  EXPECT_NO_THROW(parse_model(
      "model: x\nregisters:\n  - {address: 0, name: a, type: u32, words: 2}\n", "x.yaml"));
}

TEST(ModelTypes, AValueCutShortByTheFrameDecodesAsItsRawWord) {
  const DeviceModel model =
      parse_model("model: t\nregisters:\n  - {address: 0, name: energy, type: u32}\n", "t.yaml");
  const std::vector<uint16_t> words = {0x0001};
  Meaning meaning;
  decode_registers(model, Table::holding, 0, words, meaning);
  const std::vector<RegisterValue>& out = meaning.registers;
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].raw, 1u);
}

TEST(ModelTypes, NamedCoilsAndInputsDecodeAsBits) {
  const DeviceModel model = parse_model(
      "model: io\n"
      "registers:\n"
      "  - {address: 1, table: coil, name: pump, values: {0: Off, 1: Running}}\n"
      "  - {address: 3, table: coil, name: valve}\n"
      "  - {address: 2, table: discrete, name: door_open, access: R}\n",
      "io.yaml");
  const auto frame = [](const std::vector<uint8_t>& adu, Role role) { return frame_of(adu, role); };
  // FC01 of coils 0-7 answered 0000 1010: coil 1 and coil 3 on.
  const std::vector<uint8_t> read = {1, 0x01, 0, 0, 0, 8, 0, 0};
  const std::vector<uint8_t> answer = {1, 0x01, 1, 0x0A, 0, 0};
  Frame rsp_frame = frame(answer, Role::response);
  rsp_frame.request_pdu = std::span<const uint8_t>(read).subspan(1, 5);
  const Meaning rsp = interpret(model, rsp_frame);
  ASSERT_EQ(rsp.registers.size(), 2u);
  EXPECT_EQ(rsp.registers[0].name, "pump");
  EXPECT_EQ(rsp.registers[0].text, "Running");
  EXPECT_EQ(rsp.registers[1].name, "valve");
  EXPECT_EQ(rsp.registers[1].raw, 1u);
  // FC05 off to coil 1.
  const std::vector<uint8_t> off = {1, 0x05, 0, 1, 0, 0, 0, 0};
  const Meaning write = interpret(model, frame(off, Role::request));
  ASSERT_EQ(write.registers.size(), 1u);
  EXPECT_EQ(write.registers[0].text, "Off");
  // A write to a read-only input is not possible by function code; a coil write to an unknown
  // coil lists nothing.
  const std::vector<uint8_t> unknown = {1, 0x05, 0, 9, 0xFF, 0, 0, 0};
  EXPECT_TRUE(interpret(model, frame(unknown, Role::request)).registers.empty());
}

TEST(ModelTypes, SignedRegistersMatchNegativeNamedValuesAndWideBitFieldsAreSafe) {
  const DeviceModel model = parse_model(
      "model: s\n"
      "registers:\n"
      "  - {address: 0, name: state, type: s16, values: {-1: No fault, 0: Fault}}\n"
      "  - address: 1\n"
      "    name: wide\n"
      "    type: u32\n"
      "    bits: [{bits: [0, 31], name: everything}]\n",
      "s.yaml");
  const std::vector<uint16_t> words = {0xFFFF, 0x1234, 0x5678};
  Meaning meaning;
  decode_registers(model, Table::holding, 0, words, meaning);
  const std::vector<RegisterValue>& out = meaning.registers;
  ASSERT_EQ(out.size(), 2u);
  EXPECT_EQ(out[0].text, "No fault");
  EXPECT_EQ(out[1].text, fmt::format("everything={}", 0x12345678u));
}

// Damaged copies of the real model files: cut short, a character changed, a line duplicated.
// Each must load or give ModelError with its file and line, never another exception or a crash.
TEST(ModelFiles, DamagedFilesGiveModelErrorsOnly) {
  size_t tried = 0, refused = 0;
  for (const auto& builtin : models::builtin_models()) {
    const std::string text(builtin.yaml);
    std::vector<std::string> damaged;
    for (size_t at = 0; at < text.size(); at += 53) {
      damaged.push_back(text.substr(0, at));
      std::string changed = text;
      changed[at] = "[]{}:,-#'\"x9 \n"[at % 14];
      damaged.push_back(changed);
      const size_t line = text.rfind('\n', at);
      if (line != std::string::npos) damaged.push_back(text.substr(0, line) + text.substr(line));
    }
    for (const auto& yaml : damaged) {
      ++tried;
      try {
        const std::string base = model_base(yaml, std::string(builtin.file));
        DeviceModel base_model;
        parse_model(yaml, std::string(builtin.file), base.empty() ? nullptr : &base_model);
      } catch (const ModelError& e) {
        ++refused;
        ASSERT_FALSE(e.problems().empty());
        EXPECT_EQ(e.problems()[0].rfind(std::string(builtin.file) + ":", 0), 0u) << e.what();
      }
    }
  }
  EXPECT_GT(tried, 500u);
  EXPECT_GT(refused, tried / 4);  // the damage is mostly noticed
}

}  // namespace
}  // namespace modtap
