#include "decoder/protocol/rtu_framer.hpp"

#include <gtest/gtest.h>

#include "decoder/protocol/analyzer.hpp"
#include "decoder/protocol/checksum.hpp"
#include "tests/support/collector.hpp"

namespace modtap {
namespace {

using testing::analyze_untimed;
using testing::Collector;
using testing::expect_same_at_every_split;
using testing::hex;
using testing::Record;

const auto read_request = hex("01 03 00 00 00 0a c5 cd");
const auto read_response =
    hex("01 03 14 00 01 00 02 00 03 00 04 00 05 00 06 00 07 00 08 00 09 00 0a 8f 16");

std::vector<uint8_t> concat(std::initializer_list<std::vector<uint8_t>> parts) {
  std::vector<uint8_t> out;
  for (const auto& p : parts) out.insert(out.end(), p.begin(), p.end());
  return out;
}

std::vector<uint8_t> with_crc(std::vector<uint8_t> body) {
  const uint16_t crc = crc16(body);
  body.push_back(static_cast<uint8_t>(crc & 0xFF));
  body.push_back(static_cast<uint8_t>(crc >> 8));
  return body;
}

// NTA5000 and N3 answer errors with their own exception codes (51H-55H), which the standard
// does not name. Between a request's glitch and one after the answer, an answer whose CRC
// holds is a good frame: a CRC that holds is never printed bad.
TEST(RtuFramer, AnAnswerWhoseCrcHoldsIsNeverDamaged) {
  std::vector<uint8_t> bytes;
  for (const uint8_t code : {0x51, 0x52, 0x53, 0x54, 0x55}) {
    const auto exception = with_crc({0x01, 0x83, code});
    for (const auto& part : {read_request, hex("00"), exception, hex("ff")})
      bytes.insert(bytes.end(), part.begin(), part.end());
  }
  const auto out = analyze_untimed(bytes);
  const auto frames = out.frames();
  ASSERT_EQ(frames.size(), 10u);
  for (const auto& frame : frames) {
    EXPECT_TRUE(frame.check_ok) << frame.index;
    EXPECT_EQ(frame.damage, Damage::none) << frame.index;
    EXPECT_EQ(frame.findings & finding_bad_check, 0u) << frame.index;
  }
  EXPECT_EQ(frames[1].role, Role::response);
  EXPECT_EQ(frames[1].request, frames[0].index);
  for (const auto& glitch : out.noise()) EXPECT_EQ(glitch.reason, NoiseReason::glitch);
}

TEST(RtuFramer, SplitsARequestAndItsResponseWithNoGapBetweenThem) {
  const auto bytes = concat({read_request, read_response});
  const auto out = analyze_untimed(bytes);
  const auto frames = out.frames();
  ASSERT_EQ(frames.size(), 2u);
  EXPECT_EQ(frames[0].raw, read_request);
  EXPECT_EQ(frames[0].role, Role::request);
  EXPECT_EQ(frames[1].raw, read_response);
  EXPECT_EQ(frames[1].role, Role::response);
  EXPECT_EQ(frames[1].request, frames[0].index);
  EXPECT_TRUE(out.noise().empty());
}

TEST(RtuFramer, ARequestOutsideTheSpecsLimitsIsARequestWithAFinding) {
  // What mbpoll and pymodbus send for 126 registers, and a pymodbus slave's exception 03.
  const auto asked = hex("01 03 00 00 00 7e c5 ea"), refused = hex("01 83 03 01 31");
  // 10 coils in one byte, and FC10 with an odd byte count: the byte count still says the length.
  const auto coils = with_crc(hex("01 0f 00 00 00 0a 01 ff"));
  const auto odd = with_crc(hex("01 10 00 00 00 02 05 00 01 00 02 00"));
  const auto bytes = concat({asked, refused, coils, odd});
  const auto out = analyze_untimed(bytes);
  const auto frames = out.frames();
  ASSERT_EQ(frames.size(), 4u);
  EXPECT_TRUE(out.noise().empty());
  EXPECT_EQ(frames[0].role, Role::request);
  EXPECT_EQ(frames[0].findings, finding_quantity_out_of_spec);
  EXPECT_EQ(frames[1].role, Role::response);
  EXPECT_EQ(frames[1].request, frames[0].index);
  EXPECT_EQ(frames[2].raw, coils);
  EXPECT_EQ(frames[2].findings, finding_byte_count_mismatch);
  EXPECT_EQ(frames[3].raw, odd);
  EXPECT_EQ(frames[3].findings, finding_byte_count_mismatch);
  expect_same_at_every_split(bytes);
}

TEST(RtuFramer, AnAwaitedResponseCutShortIsABadFrameInItsSlavesPicture) {
  // The response broke off after 6 of its 25 bytes; the master moved on.
  const auto cut = std::vector<uint8_t>(read_response.begin(), read_response.begin() + 6);
  const auto out = analyze_untimed(concat({read_request, cut, read_request}));
  const auto frames = out.frames();
  ASSERT_EQ(frames.size(), 3u);
  EXPECT_EQ(frames[1].raw, cut);
  EXPECT_EQ(frames[1].role, Role::response);
  EXPECT_EQ(frames[1].request, frames[0].index);
  EXPECT_FALSE(frames[1].check_ok);
  EXPECT_EQ(frames[1].damage, Damage::cut);
  EXPECT_TRUE(out.noise().empty());
}

// A bus whose drivers put a 0x00 before every other frame, then a write whose response breaks
// off with `cut`, right before the next request.
std::vector<uint8_t> glitchy_bus_then_cut(
    const std::vector<uint8_t>& cut,
    const std::vector<uint8_t>& write = with_crc(hex("01 10 00 05 00 02 04 00 0a 01 02"))) {
  std::vector<uint8_t> bytes;
  for (int i = 0; i < 16; ++i) bytes = concat({bytes, hex("00"), read_request, read_response});
  return concat({bytes, write, cut, read_request, read_response});
}

TEST(RtuFramer, ACutResponseKeepsTheByteItsRequestSaysComesThere) {
  // FC10 echoes address and quantity: the 0x00 after the address is the quantity's high byte,
  // not a glitch, however many glitches the bus has.
  const auto cut = hex("01 10 00 05 00");
  const auto out = analyze_untimed(glitchy_bus_then_cut(cut));
  const auto frames = out.frames();
  ASSERT_GE(frames.size(), 3u);
  const auto& broken = frames[frames.size() - 3];
  EXPECT_EQ(broken.raw, cut);
  EXPECT_EQ(broken.damage, Damage::cut);
  EXPECT_EQ(broken.role, Role::response);
  EXPECT_TRUE(broken.findings & finding_ambiguous_end);  // a glitch could repeat the 0x00
  EXPECT_EQ(out.noise().size(), 16u);  // the glitches before the reads, none after the cut
}

TEST(RtuFramer, ACutResponsesLastByteThatItsRequestRulesOutIsAGlitch) {
  // 0xFF cannot be the quantity's high byte of an answer to a write of 2 registers.
  const auto out = analyze_untimed(glitchy_bus_then_cut(hex("01 10 00 05 ff")));
  const auto frames = out.frames();
  ASSERT_GE(frames.size(), 3u);
  EXPECT_EQ(frames[frames.size() - 3].raw, hex("01 10 00 05"));
  EXPECT_FALSE(frames[frames.size() - 3].findings & finding_ambiguous_end);
  ASSERT_EQ(out.noise().size(), 17u);
  EXPECT_EQ(out.noise().back().raw, hex("ff"));
  EXPECT_EQ(out.noise().back().reason, NoiseReason::glitch);
}

// On a bus whose drivers have put no glitch on the line in 128 frames and more, a byte nothing
// speaks for is the answer's own; but where the request rules the byte out, the evidence is on
// the bytes, not the bus's habit, and the byte is the next sender's glitch all the same.
TEST(RtuFramer, OnAQuietBusACutResponsesLastByteItsRequestRulesOutIsAGlitch) {
  std::vector<uint8_t> bytes;
  for (int i = 0; i < 130; ++i) bytes = concat({bytes, read_request, read_response});
  const auto write = with_crc(hex("01 10 00 05 00 02 04 00 0a 01 02"));
  for (const auto& [cut, kept] : {std::pair{hex("01 10 00 05 ff"), hex("01 10 00 05")},
                                  std::pair{hex("01 10 00 05 00"), hex("01 10 00 05 00")}}) {
    const auto out = analyze_untimed(concat({bytes, write, cut, read_request, read_response}));
    const auto frames = out.frames();
    ASSERT_GE(frames.size(), 3u);
    EXPECT_EQ(frames[frames.size() - 3].raw, kept);
    EXPECT_EQ(frames[frames.size() - 3].damage, Damage::cut);
    EXPECT_FALSE(frames[frames.size() - 3].findings & finding_ambiguous_end)
        << "a quiet bus's glitch is no runner-up, and a ruled-out byte no answer's";
    EXPECT_EQ(out.noise().size(), kept.size() < cut.size() ? 1u : 0u);
  }
}

TEST(RtuFramer, ACutEchoKeepsTheRequestsCrcByte) {
  // Mask Write Register echoes its request whole, CRC and all: its CRC's first byte is 0xFF.
  const auto mask_write = hex("01 16 00 04 ff f2 60 07 ff e3");
  const auto cut = std::vector<uint8_t>(mask_write.begin(), mask_write.begin() + 9);
  const auto out = analyze_untimed(glitchy_bus_then_cut(cut, mask_write));
  const auto frames = out.frames();
  ASSERT_GE(frames.size(), 3u);
  EXPECT_EQ(frames[frames.size() - 3].raw, cut);
  EXPECT_EQ(frames[frames.size() - 3].damage, Damage::cut);
  EXPECT_EQ(out.noise().size(), 16u);
}

TEST(RtuFramer, ARetryWhoseCrcEndsInZeroIsNotAShorterResponse) {
  // 3711 coils, over the limit; the CRC ends in 0x00, so the first 7 bytes read as a response
  // of 2 bytes with a good CRC. Sent again after a silent time-out, the copy is the request.
  const auto asked = hex("01 01 02 f5 0e 7f 68 00");
  const auto refused = with_crc(hex("01 81 03"));
  const auto bytes = concat({asked, hex("ff"), asked, refused});
  const auto out = analyze_untimed(bytes);
  const auto frames = out.frames();
  ASSERT_EQ(frames.size(), 3u);
  EXPECT_EQ(frames[0].raw, asked);
  EXPECT_EQ(frames[1].raw, asked);
  EXPECT_EQ(frames[2].raw, refused);
  expect_same_at_every_split(bytes);  // also when a read ends right before the copy's last byte
}

TEST(RtuFramer, AnAwaitedResponseRunIntoEndsWhereItsStructureSays) {
  // Another device talked over the tail: its bytes follow the response, whose CRC broke.
  auto hit = read_response;
  hit[24] ^= 0x5A;  // the last CRC byte
  const auto bytes = concat({read_request, hit, hex("a5 5a 33"), read_request});
  const auto out = analyze_untimed(bytes);
  const auto frames = out.frames();
  ASSERT_EQ(frames.size(), 3u);
  EXPECT_EQ(frames[1].raw, hit);
  EXPECT_EQ(frames[1].damage, Damage::collision);
  EXPECT_EQ(frames[1].request, frames[0].index);
  EXPECT_EQ(frames[1].expected_check, 0x168F);  // the response's own CRC, 8F 16 on the wire
  ASSERT_EQ(out.noise().size(), 1u);
  EXPECT_EQ(out.noise()[0].raw, hex("a5 5a 33"));
  EXPECT_EQ(out.bytes_of(0), bytes);
}

// Two devices answering at once: what runs on past the answer's structure is the other
// device's bytes, however they begin (here as a request of a known slave with a bad CRC), so
// they are noise after the damaged answer, never a request nor a slave of their own.
TEST(RtuFramer, WhatRunsOnPastACollidedAnswerIsNeverAFrame) {
  auto hit = read_response;
  hit[24] ^= 0x5A;
  const auto tail = hex("11 03 00 00 00 01 aa bb");  // reads as FC03 to slave 17, check bad
  const auto bytes = concat({read_request, hit, tail, read_request});
  const auto out = analyze_untimed(bytes);
  const auto frames = out.frames();
  ASSERT_EQ(frames.size(), 3u);
  EXPECT_EQ(frames[1].raw, hit);
  EXPECT_EQ(frames[1].damage, Damage::collision);
  EXPECT_EQ(frames[2].raw, read_request);
  ASSERT_EQ(out.noise().size(), 1u);
  EXPECT_EQ(out.noise()[0].raw, tail);
  expect_same_at_every_split(bytes);
}

TEST(RtuFramer, GivesTheSameRecordsWhereverTheInputIsCut) {
  expect_same_at_every_split(concat({read_request, read_response, hex("00"), read_request,
                                     hex("11 22"), read_request, read_response}));
}

TEST(RtuFramer, KeepsAGlitchByteBeforeAResponseAsNoise) {
  const auto bytes = concat({read_request, hex("00"), read_response});
  const auto out = analyze_untimed(bytes);
  ASSERT_EQ(out.stream().size(), 3u);
  EXPECT_EQ(out.stream()[1].type, Record::Type::noise);
  EXPECT_EQ(out.stream()[1].reason, NoiseReason::glitch);
  EXPECT_EQ(out.stream()[2].raw, read_response);
  EXPECT_EQ(out.stream()[2].request, out.stream()[0].index);
}

TEST(RtuFramer, DoesNotSwallowATrailingZeroIntoTheFrame) {
  const auto bytes = concat({read_request, hex("00")});
  const auto out = analyze_untimed(bytes);
  ASSERT_EQ(out.stream().size(), 2u);
  EXPECT_EQ(out.stream()[0].raw, read_request);
  EXPECT_EQ(out.stream()[1].raw, hex("00"));
}

TEST(RtuFramer, ReportsABadCrcFrameWithTheExpectedValue) {
  auto damaged = read_request;
  damaged[5] = 0x0b;  // quantity 11, CRC still that of quantity 10
  const auto bytes = concat({damaged, read_request});
  const auto out = analyze_untimed(bytes);
  const auto frames = out.frames();
  ASSERT_EQ(frames.size(), 2u);
  EXPECT_FALSE(frames[0].check_ok);
  EXPECT_EQ(frames[0].raw, damaged);
  EXPECT_EQ(frames[0].expected_check, 0x0D04);  // CRC of 01 03 00 00 00 0b
  EXPECT_TRUE(frames[1].check_ok);
}

TEST(RtuFramer, TurnsATruncatedFrameIntoNoiseAndFindsTheNextOne) {
  const auto bytes = concat({hex("01 03 00 00"), read_request});
  const auto out = analyze_untimed(bytes);
  ASSERT_EQ(out.stream().size(), 2u);
  EXPECT_EQ(out.stream()[0].type, Record::Type::noise);
  EXPECT_EQ(out.stream()[0].reason, NoiseReason::truncated);
  EXPECT_EQ(out.stream()[1].raw, read_request);
}

// A request broken off before its last CRC byte, where that byte is its slave's address: the
// broken-off bytes and the first byte of the request sent again at once read as the whole
// request, its CRC holding (1 cut in 256). What follows says otherwise: the same slave and
// function code start again inside that span as a request that runs past it, and the span's
// bytes before it are that request's own first bytes (`resent-inside`). With no clock to see
// the pause between, the broken-off bytes are no good frame, and the request sent again is the
// frame, answered or not.
TEST(RtuFramer, ARequestBrokenOffAndSentAgainIsNoFrameOfItsFirstBytes) {
  std::vector<uint8_t> request;
  for (uint16_t address = 0;; ++address) {  // an FC03 read whose CRC ends in its slave address
    request = with_crc({0x11, 0x03, static_cast<uint8_t>(address >> 8),
                        static_cast<uint8_t>(address & 0xFF), 0x00, 0x01});
    if (request.back() == 0x11) break;
  }
  const std::vector<uint8_t> broken_off(request.begin(), request.end() - 1);
  const auto answer = with_crc({0x11, 0x03, 0x02, 0x12, 0x34});
  for (const auto& after : {answer, read_request}) {  // its answer, or the next slave's request
    const auto bytes = concat({broken_off, request, after});
    ASSERT_TRUE(rtu_crc_holds({bytes.data(), request.size()}));  // the reading refuted
    const auto out = analyze_untimed(bytes);
    ASSERT_EQ(out.stream().size(), 3u);
    EXPECT_EQ(out.stream()[0].raw, broken_off);  // noise, or a damaged frame of its header
    EXPECT_FALSE(out.stream()[0].check_ok);
    EXPECT_EQ(out.stream()[1].raw, request);
    EXPECT_EQ(out.stream()[1].role, Role::request);
    EXPECT_TRUE(out.stream()[1].check_ok);
    EXPECT_EQ(out.stream()[2].raw, after);
    expect_same_at_every_split(bytes);
  }
}

// The verdict is the weights': the same bytes, with a feature of the refuting row weighing
// nothing, or a CRC weighing more than any row, keep the span the table refutes.
TEST(RtuFramer, AFeaturesWeightDecidesWhetherItsRowRefutesASpan) {
  std::vector<uint8_t> request;
  for (uint16_t address = 0;; ++address) {  // as above: a read whose CRC ends in its slave
    request = with_crc({0x11, 0x03, static_cast<uint8_t>(address >> 8),
                        static_cast<uint8_t>(address & 0xFF), 0x00, 0x01});
    if (request.back() == 0x11) break;
  }
  const std::vector<uint8_t> broken_off(request.begin(), request.end() - 1);
  const auto bytes = concat({broken_off, request, read_request});
  const std::vector<uint8_t> span(bytes.begin(), bytes.begin() + 8);
  ASSERT_TRUE(rtu_crc_holds(span));
  EXPECT_EQ(analyze_untimed(bytes).stream()[1].raw, request);  // resent-inside refutes the span
  for (const FeatureWeights& weights : {table_weights.with(Feature::broken_off_copy, 0),
                                        table_weights.with(Feature::crc_holds, 40)}) {
    const auto out = analyze_untimed(bytes, {}, ModeChoice::rtu, weights);
    ASSERT_FALSE(out.stream().empty());
    EXPECT_EQ(out.stream()[0].raw, span);
    EXPECT_TRUE(out.stream()[0].check_ok);
    EXPECT_EQ(out.stream()[0].role, Role::request);
  }
}

// An answer that begins as its request, byte for byte, after its driver's glitch: FC12's byte
// count and first status byte the request's CRC (1 answer in 65,536). Read apart, the copy
// would be the master's retry and leave the rest of the answer to junk, no frame starting
// after it; the answer, whose length rules and CRC agree, stands, with no clock to say how soon
// it came (rough seed 277).
TEST(RtuFramer, AnAnswerThatBeginsAsItsRequestIsNoRetryWhereJunkWouldFollowTheCopy) {
  std::vector<uint8_t> request;
  for (uint8_t slave = 1;; ++slave) {  // a CRC whose low byte is a byte count FC12 may answer
    request = with_crc({slave, 0x0C});
    if (request[2] >= 6 && request[2] <= 70) break;
  }
  std::vector<uint8_t> answer(request.begin(), request.end());  // slave, 0C, count, status hi
  while (answer.size() < size_t{3} + request[2])  // the log's bytes, as no frame begins
    answer.push_back(static_cast<uint8_t>(0x99 + 37 * answer.size()));
  answer = with_crc(answer);
  const auto glitch = hex("ff");  // the answering driver turning on
  const auto bytes = concat({request, glitch, answer, read_request});
  const auto out = analyze_untimed(bytes);
  ASSERT_EQ(out.stream().size(), 4u);
  EXPECT_EQ(out.stream()[0].raw, request);
  EXPECT_EQ(out.stream()[1].raw, glitch);
  EXPECT_EQ(out.stream()[2].raw, answer);
  EXPECT_EQ(out.stream()[2].role, Role::response);
  EXPECT_EQ(out.stream()[2].request, out.stream()[0].index);
  EXPECT_EQ(out.stream()[3].raw, read_request);
  expect_same_at_every_split(bytes);
}

TEST(RtuFramer, KeepsEveryByteOfEndlessJunkInBoundedNoiseRecords) {
  std::vector<uint8_t> junk(1 << 20);
  uint32_t x = 12345;
  for (auto& b : junk) {
    x = x * 1103515245 + 12345;
    b = static_cast<uint8_t>(x >> 24);
  }
  const auto out = analyze_untimed(junk, {1000, 70000, 500000});
  EXPECT_EQ(out.bytes_of(0), junk);
  for (const auto& r : out.records) EXPECT_LE(r.raw.size(), 256u);
  // Random bytes can hold a CRC-good frame by chance; it must stay rare.
  EXPECT_LT(out.frames().size(), 20u);
}

TEST(RtuFramer, FramesReservedAddressesWithPublicFunctionCodes) {
  // N3 answers to stations up to 254 (FEH): "Max to No. 254 (FEH)".
  const auto bytes = concat({hex("fe 03 01 20 00 01 90 33"), hex("fe 03 02 00 05 6c 53")});
  const auto frames = analyze_untimed(bytes).frames();
  ASSERT_EQ(frames.size(), 2u);
  EXPECT_EQ(frames[0].role, Role::request);
  EXPECT_EQ(frames[1].role, Role::response);
  EXPECT_EQ(frames[1].request, frames[0].index);
  expect_same_at_every_split(bytes);
}

// FFH then a vendor's code, no CRC holding anywhere: a glitch and junk. With neither a CRC nor a
// length of its own, only its header could make it a damaged frame, and at a reserved address a
// vendor's code is junk's more often than a device's.
TEST(RtuFramer, AVendorCodeAtAReservedAddressIsJunkNotADamagedFrame) {
  const auto junk = hex("ff 41 00 00 00 00 00 00 00 00");
  const auto out = analyze_untimed(concat({junk, read_request}));
  const auto frames = out.frames();
  ASSERT_EQ(frames.size(), 1u);
  EXPECT_EQ(frames[0].raw, read_request);
  EXPECT_EQ(out.bytes_of(0), concat({junk, read_request}));
}

// An exception whose code the standard does not name is a vendor's code as much as a vendor's
// function is (`bus-code`: a public function code, and for an exception a code the standard
// names): at a reserved address, with no CRC holding, junk; the same header with a standard code
// stays a damaged answer.
TEST(RtuFramer, AnUnnamedExceptionCodeAtAReservedAddressIsJunkNotADamagedFrame) {
  const auto unnamed = hex("f8 83 19 00 00");
  const auto junk = analyze_untimed(concat({unnamed, read_request}));
  ASSERT_EQ(junk.frames().size(), 1u);
  EXPECT_EQ(junk.frames()[0].raw, read_request);
  ASSERT_EQ(junk.noise().size(), 1u);
  EXPECT_EQ(junk.noise()[0].raw, unnamed);

  const auto named = hex("f8 83 02 00 00");
  const auto damaged = analyze_untimed(concat({named, read_request})).frames();
  ASSERT_EQ(damaged.size(), 2u);
  EXPECT_EQ(damaged[0].raw, named);
  EXPECT_FALSE(damaged[0].check_ok);
  EXPECT_EQ(damaged[1].raw, read_request);
}

// The frames `out` holds are `expected`, in order, and its noise `glitches` lone glitches.
void expect_frames_and_glitches(const Collector& out,
                                const std::vector<std::vector<uint8_t>>& expected,
                                size_t glitches) {
  const auto frames = out.frames();
  ASSERT_EQ(frames.size(), expected.size());
  for (size_t i = 0; i < expected.size(); ++i) EXPECT_EQ(frames[i].raw, expected[i]) << i;
  ASSERT_EQ(out.noise().size(), glitches);
  for (const auto& glitch : out.noise()) EXPECT_EQ(glitch.reason, NoiseReason::glitch);
}

// A turnaround's 0xFF, a loop test to station 43 (FC08 Return Query Data, no fixed length), the
// answering driver's 0x00 and the echo pass one CRC as a frame from station 255, which the next
// request confirms (fresh seed 472). The query whose exact copy follows after a glitch is a frame
// a bus carries inside that span, and outweighs it (swallows-known-frame): a glitch, the query,
// a glitch, the echo.
TEST(RtuFramer, AQueryAndItsEchoAfterAGlitchAreNoFrameOfTheGlitchBeforeThem) {
  const auto query = hex("2b 08 00 00 46 14 80 e0 b3 02 41 f7 92 99");
  const auto next = hex("2a 06 8e 89 9a f9 df f1");
  const auto bytes = concat({hex("ff"), query, hex("00"), query, next});
  ASSERT_TRUE(rtu_crc_holds(std::span(bytes).first(2 * query.size() + 2)));
  const auto out = analyze_untimed(bytes);
  ASSERT_NO_FATAL_FAILURE(expect_frames_and_glitches(out, {query, query, next}, 2));
  const auto frames = out.frames();
  EXPECT_EQ(frames[0].role, Role::request);
  EXPECT_EQ(frames[1].role, Role::response);
  EXPECT_EQ(frames[1].request, frames[0].index);
}

// A turnaround's 0xFF before an answer cut short, whose station's number reads as a vendor's
// code (station 18, 12H): its bytes pass a CRC from the 0xFF, and the glitch and request after
// them confirm that end. Read as an answer or as a request to station 255, it starts at the
// answering driver's glitch and runs over the awaited answer's header, and no clock is needed to
// say so: a glitch, the answer (cut), a glitch, the next request.
TEST(RtuFramer, A0xFFBeforeTheAwaitedAnswerIsNoFrameOfStation255InEitherRole) {
  const auto request = hex("12 2b 0e 01 00 f5 b4");
  const auto cut_answer = hex("12 2b 0e 01 81 00 00 03 00");
  const auto next = hex("10 06 ab 63 bc 31 eb a5");
  ASSERT_TRUE(rtu_crc_holds(concat({hex("ff"), cut_answer})));
  const auto out = analyze_untimed(concat({request, hex("ff"), cut_answer, hex("ff"), next}));
  ASSERT_NO_FATAL_FAILURE(expect_frames_and_glitches(out, {request, cut_answer, next}, 2));
  const auto frames = out.frames();
  EXPECT_EQ(frames[1].damage, Damage::cut);
  EXPECT_EQ(frames[1].request, frames[0].index);
}

// N3 answers to stations up to 254. Its loop test to station 250 that nobody answers, with junk
// after it, stands on its header and CRC at the input's end, as station 17's does.
TEST(RtuFramer, ALoopTestToAReservedStationStandsOnItsHeaderAsAnyStationsDoes) {
  for (const uint8_t station : {17, 250}) {
    const auto query = with_crc({station, 0x08, 0x00, 0x00, 0x12, 0x34});
    const auto frames = analyze_untimed(concat({query, hex("a5 5a 3c")})).frames();
    ASSERT_EQ(frames.size(), 1u) << "station " << int{station};
    EXPECT_EQ(frames[0].raw, query);
    EXPECT_TRUE(frames[0].check_ok);
  }
}

// A public function whose header does not tell its length (FC08 Return Query Data, FC2B/0D
// CANopen General Reference) stands on its header and CRC with junk after it, once nothing
// can confirm its end; a vendor's code, junk's code 5 times in 6, does not.
TEST(RtuFramer, APublicFunctionOfAnyLengthStandsOnItsHeaderAndAVendorCodeDoesNot) {
  const auto junk = hex("a5 5a 3c");
  for (const auto& query : {with_crc({17, 0x08, 0x00, 0x00, 0x12, 0x34}),
                            with_crc({17, 0x2B, 0x0D, 0x00, 0x01, 0x12, 0x34})}) {
    const auto frames = analyze_untimed(concat({query, junk})).frames();
    ASSERT_EQ(frames.size(), 1u) << "function " << int{query[1]};
    EXPECT_EQ(frames[0].raw, query);
    EXPECT_TRUE(frames[0].check_ok);
  }
  const auto vendor = with_crc({17, 0x41, 0x00, 0x00, 0x12, 0x34});
  for (const auto& frame : analyze_untimed(concat({vendor, junk})).frames())
    EXPECT_FALSE(frame.check_ok) << "a vendor's code stood on its header";
}

TEST(RtuFramer, FindsAnUnknownFunctionCodeByCrcWhenTheNextFrameConfirmsIt) {
  const auto vendor = hex("05 41 01 02 03");
  std::vector<uint8_t> frame = vendor;
  const uint16_t crc = crc16(vendor);
  frame.push_back(static_cast<uint8_t>(crc & 0xFF));
  frame.push_back(static_cast<uint8_t>(crc >> 8));
  const auto out = analyze_untimed(concat({frame, read_request}));
  const auto frames = out.frames();
  ASSERT_EQ(frames.size(), 2u);
  EXPECT_EQ(frames[0].raw, frame);
  EXPECT_EQ(frames[1].raw, read_request);
}

// A bus at 9600 8N1, read in `mode` with `clock`.
AnalyzerOptions at_9600(ModeChoice mode, ClockQuality clock) {
  AnalyzerOptions options;
  options.mode = mode;
  options.clock = clock;
  options.format = {9600, 8, Parity::none, 1};
  return options;
}

// Bytes of unknown length ahead of a response keep the framer waiting for their end; the
// matcher's clock must not run past them, or the request times out before its response
// comes out, however soon the slave answered.
TEST(Analyzer, DoesNotTimeARequestOutWhileItsResponseIsStillHeld) {
  const AnalyzerOptions options = at_9600(ModeChoice::rtu, ClockQuality::per_byte);
  Collector out;
  Analyzer analyzer(options, {{"bus", ChannelRole::bus}}, out);
  const int64_t char_ns = options.format.char_time_ns();
  int64_t t = 0;
  auto send = [&](const std::vector<uint8_t>& bytes, int64_t gap_ns) {
    t += gap_ns;
    for (uint8_t b : bytes) analyzer.push({0, t += char_ns, {&b, 1}});
  };
  send(with_crc(hex("01 03 00 00 00 01")), 0);
  // A broadcast of vendor code 41H has no length rule: it may run on until a silence and a
  // frame after it say where it ended.
  send(hex("00 41"), 5'000'000);
  send(with_crc(hex("01 03 02 00 2a")), 0);
  send(with_crc(hex("02 03 00 00 00 01")), 2'000'000'000);
  analyzer.finish();

  const auto frames = out.frames();
  ASSERT_EQ(frames.size(), 3u);
  EXPECT_EQ(frames[1].role, Role::response);
  EXPECT_EQ(frames[1].request, frames[0].index);
  for (const auto& timeout : out.timeouts()) EXPECT_NE(timeout.request, frames[0].index);
}

TEST(Analyzer, AQuietLiveBusShowsItsFirstFrameAtTheSilenceInAutomaticMode) {
  // One request a second: waiting for three good frames before choosing RTU or ASCII would
  // show nothing for three seconds. The silence after one frame, good only as RTU, decides.
  const AnalyzerOptions options = at_9600(ModeChoice::automatic, ClockQuality::per_chunk);
  Collector out;
  Analyzer analyzer(options, {{"bus", ChannelRole::bus}}, out);
  analyzer.push({0, 1'000'000'000, read_request});
  analyzer.flush(1'100'000'000);
  const auto frames = out.frames();
  ASSERT_EQ(frames.size(), 1u);
  EXPECT_EQ(frames[0].raw, read_request);
}

class GapCollector : public ::testing::Test {
 protected:
  // Pushes each byte with its own exact time: bytes of a frame back to back, then `gap_ns`.
  Collector run_per_byte(const std::vector<std::vector<uint8_t>>& frames, int64_t gap_ns) {
    std::vector<Piece> pieces;
    for (const auto& f : frames) pieces.push_back({gap_ns, f});
    return run(pieces, ClockQuality::per_byte);
  }

  // Bytes sent back to back after `silence_ns`; a clock per byte times each, one per chunk
  // stamps the piece as one read.
  struct Piece {
    int64_t silence_ns;
    std::vector<uint8_t> bytes;
  };
  // A request, its slave's driver's `glitch` and the awaited answer, split into two reads at
  // every offset (a timer's reads end anywhere: no silence to tell by), then the next request:
  // the glitch is noise and the answer good and paired, whatever the glitch and the answer's
  // first bytes pass a CRC as.
  void expect_glitch_then_answer(const std::vector<uint8_t>& request, uint8_t glitch,
                                 const std::vector<uint8_t>& answer) {
    std::vector<uint8_t> bytes = request;
    bytes.push_back(glitch);
    bytes.insert(bytes.end(), answer.begin(), answer.end());
    for (size_t split = 1; split < bytes.size(); ++split) {
      const std::vector<Piece> pieces{
          {20'000'000, std::vector<uint8_t>(bytes.begin(), bytes.begin() + split)},
          {0, std::vector<uint8_t>(bytes.begin() + split, bytes.end())},
          {20'000'000, read_request}};
      const auto stream = run(pieces, ClockQuality::per_chunk).stream();
      ASSERT_EQ(stream.size(), 4u) << split;
      EXPECT_EQ(stream[1].reason, NoiseReason::glitch) << split;
      EXPECT_EQ(stream[2].raw, answer) << split;
      EXPECT_EQ(stream[2].role, Role::response) << split;
      EXPECT_TRUE(stream[2].check_ok) << split;
      EXPECT_EQ(stream[2].request, stream[0].index) << split;
      EXPECT_EQ(stream[3].raw, read_request) << split;
    }
  }

  // 16 transactions, each after a 0x00 glitch: a bus where 0x00 glitches are common.
  static std::vector<Piece> glitchy_history() {
    std::vector<Piece> pieces;
    for (int i = 0; i < 16; ++i) {
      pieces.push_back({20'000'000, hex("00")});
      pieces.push_back({1'000'000, read_request});
      pieces.push_back({2'000'000, read_response});
    }
    return pieces;
  }

  // `finish`: end the input after the pieces, or leave the analyzer holding what it holds.
  Collector run(const std::vector<Piece>& pieces, ClockQuality clock, bool finish = true) {
    Collector out;
    const AnalyzerOptions options = at_9600(ModeChoice::rtu, clock);
    Analyzer analyzer(options, {{"bus", ChannelRole::bus}}, out);
    const int64_t char_ns = options.format.char_time_ns();
    int64_t t = 0;
    for (const auto& piece : pieces) {
      t += piece.silence_ns;
      for (const uint8_t& b : piece.bytes) {
        t += char_ns;
        if (clock == ClockQuality::per_byte) analyzer.push({0, t, {&b, 1}});
      }
      if (clock != ClockQuality::per_byte) analyzer.push({0, t, piece.bytes});
    }
    if (finish) analyzer.finish();
    return out;
  }
};

// At 9600 baud a character is 1.04 ms: t1.5 is 1.56 ms and t3.5 3.65 ms.

// A read's answer cut after a data byte 0x00, the next request right behind it, on a bus of
// 0x00 glitches: the 0x00 is the answer's own or the next driver's glitch. A clock per byte
// sees it sent with no pause before it; a clock per read cannot, and the frame says so.
TEST_F(GapCollector, ACutResponsesLastByteThatMayBeAGlitchIsSaidToBeEither) {
  std::vector<Piece> pieces = glitchy_history();
  const auto cut = hex("01 03 14 00 01 00");
  pieces.push_back({20'000'000, read_request});
  pieces.push_back({2'000'000, concat({cut, read_request})});
  pieces.push_back({2'000'000, read_response});
  for (ClockQuality clock : {ClockQuality::per_byte, ClockQuality::per_chunk}) {
    const auto out = run(pieces, clock);
    const auto frames = out.frames();
    ASSERT_EQ(frames.size(), 36u);
    const auto& broken = frames[33];
    EXPECT_EQ(broken.damage, Damage::cut);
    EXPECT_EQ(broken.role, Role::response);
    if (clock == ClockQuality::per_byte) {
      EXPECT_EQ(broken.raw, cut);
      EXPECT_FALSE(broken.findings & finding_ambiguous_end);
    } else {
      EXPECT_EQ(broken.raw, hex("01 03 14 00 01"));
      EXPECT_TRUE(broken.findings & finding_ambiguous_end);
      EXPECT_EQ(out.noise().back().raw, hex("00"));
    }
  }
  // A clock per byte that sees the line quiet before the 0x00 cannot rule a glitch out either.
  pieces.end()[-2] = {2'000'000, hex("01 03 14 00 01")};
  pieces.insert(pieces.end() - 1, {3'000'000, concat({hex("00"), read_request})});
  const auto frames = run(pieces, ClockQuality::per_byte).frames();
  ASSERT_EQ(frames.size(), 36u);
  EXPECT_EQ(frames[33].raw, hex("01 03 14 00 01"));
  EXPECT_TRUE(frames[33].findings & finding_ambiguous_end);
}

TEST_F(GapCollector, APauseOverT15InsideAFrameIsAFindingNotABoundary) {
  const auto head = hex("01 03 00"), tail = hex("00 00 0a c5 cd");
  for (ClockQuality clock : {ClockQuality::per_byte, ClockQuality::per_chunk}) {
    const auto paused = run({{0, head}, {2'500'000, tail}}, clock).frames();
    ASSERT_EQ(paused.size(), 1u);
    EXPECT_TRUE(paused[0].check_ok);
    EXPECT_EQ(paused[0].raw, read_request);
    // A clock per read cannot time a pause of a character or two.
    EXPECT_EQ(paused[0].findings & finding_gap_in_frame,
              clock == ClockQuality::per_byte ? finding_gap_in_frame : 0u);
  }
  const auto steady = run({{0, head}, {1'000'000, tail}}, ClockQuality::per_byte).frames();
  ASSERT_EQ(steady.size(), 1u);
  EXPECT_EQ(steady[0].findings & finding_gap_in_frame, 0u);
}

// FC08 Return Query Data has no fixed length: its CRC needs something after it to confirm its
// end. A pause over t1.5 does, so junk right after it (a slave at another baud rate) is no
// part of it.
TEST_F(GapCollector, APauseAfterAGoodCrcEndsAFrameOfNoFixedLength) {
  const auto query = with_crc(hex("35 08 00 00 dc 49"));
  const auto junk = hex("81 7b 3c 20 97 01 f2 04 63");
  const auto out =
      run({{0, query}, {2'000'000, junk}, {10'000'000, read_request}}, ClockQuality::per_byte);
  const auto stream = out.stream();
  ASSERT_EQ(stream.size(), 3u);
  EXPECT_EQ(stream[0].raw, query);
  EXPECT_TRUE(stream[0].check_ok);
  EXPECT_EQ(stream[0].role, Role::request);
  EXPECT_EQ(stream[1].raw, junk);
  EXPECT_EQ(stream[1].findings & finding_garbage_after_request, finding_garbage_after_request);
  EXPECT_EQ(stream[2].raw, read_request);
}

// N3 answers to stations up to 254 (reserved by the standard), and its loop test is FC08
// Return Query Data, which has no fixed length. A query and its echo read in one chunk are two
// frames, paired, found by the CRC search as for any station.
TEST_F(GapCollector, ALoopTestToAReservedStationAndItsEchoInOneReadAreTwoFrames) {
  for (uint8_t station = 248; station <= 254; ++station) {
    const auto query = with_crc({station, 0x08, 0x00, 0x00, 0x12, 0x34});
    auto query_and_echo = query;
    query_and_echo.insert(query_and_echo.end(), query.begin(), query.end());
    const auto out =
        run({{0, query_and_echo}, {20'000'000, read_request}}, ClockQuality::per_chunk);
    const auto frames = out.frames();
    ASSERT_EQ(frames.size(), 3u) << "station " << int{station};
    EXPECT_EQ(frames[0].raw, query);
    EXPECT_EQ(frames[0].role, Role::request);
    EXPECT_EQ(frames[1].raw, query);
    EXPECT_EQ(frames[1].role, Role::response);
    EXPECT_EQ(frames[1].request, frames[0].index);
    EXPECT_TRUE(frames[0].check_ok && frames[1].check_ok);
  }
}

// A vendor's request and its exact copy, then junk: nothing confirms the request's end but the
// copy behind it, the same CRC by chance twice over (no silence, no frame after it, and a
// vendor's code has no header to stand on). The copy, with the junk after it, is the answer,
// damaged.
TEST_F(GapCollector, AnExactCopyConfirmsTheEndOfAFrameNoLengthRuleBounds) {
  const auto request = with_crc(hex("05 41 12 34"));
  const auto junk = hex("55 aa 55");
  const auto out = run({{0, concat({request, request, junk})}, {20'000'000, read_request}},
                       ClockQuality::per_chunk);
  const auto frames = out.frames();
  ASSERT_EQ(frames.size(), 3u);
  EXPECT_EQ(frames[0].raw, request);
  EXPECT_TRUE(frames[0].check_ok);
  EXPECT_EQ(frames[1].raw, concat({request, junk}));
  EXPECT_FALSE(frames[1].check_ok);
  EXPECT_EQ(frames[2].raw, read_request);
}

// Where each byte is timed, a pause over t1.5 right after a CRC that holds ends the frame: no
// frame goes on across one (Serial Line 2.5.1.1). A vendor's request, then a slave answering at
// another baud rate 2.5 ms on (t1.5 is 1.7 ms at 9600 baud, t3.5 4 ms): the request stands,
// the junk is noise.
TEST_F(GapCollector, APauseOverT15ConfirmsTheEndOfAFrameNoLengthRuleBounds) {
  const auto vendor = hex("01 41 02 03 10 ad");
  const auto junk = hex("55 aa 55 aa");
  const auto out = run({{20'000'000, vendor}, {2'500'000, junk}, {20'000'000, read_request}},
                       ClockQuality::per_byte);
  const auto frames = out.frames();
  ASSERT_EQ(frames.size(), 2u);
  EXPECT_EQ(frames[0].raw, vendor);
  EXPECT_TRUE(frames[0].check_ok);
  EXPECT_EQ(frames[1].raw, read_request);
  ASSERT_EQ(out.noise().size(), 1u);
  EXPECT_EQ(out.noise()[0].raw, junk);
}

// A frame of no fixed length whose CRC ends in 0x00 holds a good frame one byte shorter: the
// 0x00 is the frame's own or the next driver's glitch. A clock per byte that saw the 0x00 sent
// straight on after the byte before it tells: no driver turned on there, so it is the frame's,
// and the frame's end is in no doubt. With a clock per read nothing tells, and the shorter
// frame and a glitch is the reading, marked as in doubt.
TEST_F(GapCollector, AZeroSentStraightOnIsTheFramesOwnNotAGlitch) {
  const auto vendor = concat({with_crc(hex("01 41 02 03")), hex("00")});
  const auto per_byte = run({{20'000'000, vendor}, {0, read_request}}, ClockQuality::per_byte);
  ASSERT_EQ(per_byte.frames().size(), 2u);
  EXPECT_EQ(per_byte.frames()[0].raw, vendor);
  EXPECT_EQ(per_byte.frames()[0].findings & finding_ambiguous_end, 0u);
  EXPECT_TRUE(per_byte.noise().empty());

  const auto per_read =
      run({{20'000'000, concat({vendor, read_request})}}, ClockQuality::per_chunk).stream();
  ASSERT_EQ(per_read.size(), 3u);
  EXPECT_EQ(per_read[0].raw, with_crc(hex("01 41 02 03")));
  EXPECT_EQ(per_read[0].findings & finding_ambiguous_end, finding_ambiguous_end);
  EXPECT_EQ(per_read[1].raw, hex("00"));
  EXPECT_EQ(per_read[2].raw, read_request);
}

// Noise while a request waits is marked with that request; a glitch, or noise once the request
// was answered, is not.
TEST_F(GapCollector, NoiseWhereAnAnswerWasAwaitedIsGarbageAfterTheRequest) {
  const auto junk = hex("f3 81 7b");
  const auto out = run({{0, read_request},
                        {5'000'000, hex("00")},
                        {5'000'000, junk},
                        {10'000'000, read_request},
                        {5'000'000, read_response},
                        {5'000'000, junk}},
                       ClockQuality::per_byte);
  const auto noise = out.noise();
  ASSERT_EQ(noise.size(), 3u);
  EXPECT_EQ(noise[0].reason, NoiseReason::glitch);
  EXPECT_EQ(noise[0].findings, 0u);
  EXPECT_EQ(noise[1].raw, junk);
  EXPECT_EQ(noise[1].findings, finding_garbage_after_request);
  EXPECT_EQ(noise[1].request, out.frames()[0].index);
  EXPECT_EQ(noise[2].findings, 0u);
  EXPECT_FALSE(noise[2].request.has_value());
}

TEST_F(GapCollector, CutsATruncatedFrameAtASilence) {
  const auto out = run_per_byte({hex("01 03 00 00 00"), read_request}, 10'000'000);
  ASSERT_EQ(out.stream().size(), 2u);
  EXPECT_EQ(out.stream()[0].type, Record::Type::noise);
  EXPECT_EQ(out.stream()[0].raw, hex("01 03 00 00 00"));
  EXPECT_EQ(out.stream()[1].raw, read_request);
}

TEST_F(GapCollector, MeasuresLatencyFromRequestEndToResponseStart) {
  const auto out = run_per_byte({read_request, read_response}, 5'000'000);
  const auto frames = out.frames();
  ASSERT_EQ(frames.size(), 2u);
  ASSERT_TRUE(frames[1].latency_ns.has_value());
  EXPECT_EQ(*frames[1].latency_ns, 5'000'000);
}

TEST_F(GapCollector, ReportsATimeoutAfterSilence) {
  const auto out = run_per_byte({read_request, read_request}, 1'500'000'000);
  const auto timeouts = out.timeouts();
  ASSERT_EQ(timeouts.size(), 2u);
  EXPECT_EQ(timeouts[0].timeout_reason, TimeoutReason::silence);
  EXPECT_EQ(timeouts[1].timeout_reason, TimeoutReason::end_of_capture);
}

// One driver turning on puts one glitch on the line: a read's answer cut after "01 03 14 00 01
// 00 00", the next request right behind it on a bus of 0x00 glitches, keeps the first 0x00 (the
// second may be the next driver's glitch; both cannot be).
TEST_F(GapCollector, ACutResponseLosesAtMostOneTrailingByteToAGlitch) {
  std::vector<Piece> pieces = glitchy_history();
  pieces.push_back({20'000'000, read_request});
  pieces.push_back({2'000'000, concat({hex("01 03 14 00 01 00 00"), read_request})});
  pieces.push_back({2'000'000, read_response});
  const auto out = run(pieces, ClockQuality::per_chunk);
  const auto frames = out.frames();
  ASSERT_EQ(frames.size(), 36u);
  EXPECT_EQ(frames[33].raw, hex("01 03 14 00 01 00"));
  EXPECT_EQ(frames[33].damage, Damage::cut);
  EXPECT_TRUE(frames[33].findings & finding_ambiguous_end);
  EXPECT_EQ(out.noise().back().raw, hex("00"));
}

// A collision's junk can hold bytes that pass a CRC. Inside the span the awaited answer's
// structure claims, a vendor code's frame is not taken: the bytes are the answer, talked over.
TEST(RtuFramer, AVendorCodeInsideACollidedAnswerIsPartOfTheAnswer) {
  const auto write = with_crc(hex("0d 06 00 01 00 05"));
  const auto junk = with_crc(hex("30 44 07"));  // FC 44H, no public code, and a good CRC
  const auto next = with_crc(hex("14 03 00 00 00 01"));
  const auto bytes = concat({write, hex("0d 06 00 01"), junk, next});
  const auto out = analyze_untimed(bytes);
  const auto frames = out.frames();
  ASSERT_EQ(frames.size(), 3u);
  EXPECT_EQ(frames[1].raw, hex("0d 06 00 01 30 44 07 03"));
  EXPECT_EQ(frames[1].role, Role::response);
  EXPECT_EQ(frames[1].damage, Damage::collision);
  EXPECT_EQ(frames[2].raw, next);
  expect_same_at_every_split(bytes);
}

// A FC08 Return Query Data request whose CRC ends in 0x00, and its echo, on a bus of 0x00
// glitches where one read holds them: each is a good frame one byte shorter with a glitch after
// it, or itself; both say so.
TEST_F(GapCollector, AnEchoPairWhoseCrcEndsInZeroSaysItsEndIsInDoubt) {
  std::vector<Piece> pieces = glitchy_history();
  const auto query = hex("11 08 00 00 00 da 63 00");
  pieces.push_back({20'000'000, concat({query, query, read_request})});
  pieces.push_back({2'000'000, read_response});
  const auto out = run(pieces, ClockQuality::per_chunk);
  const auto frames = out.frames();
  ASSERT_EQ(frames.size(), 36u);
  EXPECT_EQ(frames[32].role, Role::request);
  EXPECT_TRUE(frames[32].findings & finding_ambiguous_end);
  EXPECT_EQ(frames[33].role, Role::response);
  EXPECT_EQ(frames[33].request, frames[32].index);
  EXPECT_TRUE(frames[33].findings & finding_ambiguous_end);
}

// The same query on a bus of 0x00 glitches, then its slave's 0xFF and its exception talked
// over (fresh seed 5514): one byte shorter, the query would need two glitches at one
// turnaround, the 0x00 and the 0xFF before its answer's slave and function code. The query
// keeps its 0x00, though nothing but its header confirms it, and its answer is paired.
TEST_F(GapCollector, AQueryKeepsItsZeroWhereTakingItForAGlitchNeedsASecond) {
  std::vector<Piece> pieces = glitchy_history();
  const auto query = hex("11 08 00 00 00 da 63 00");
  const auto talked_over = hex("11 88 01 5c 7a");
  ASSERT_NE(crc16(talked_over), 0);
  pieces.push_back({20'000'000, concat({query, hex("ff"), talked_over})});
  pieces.push_back({20'000'000, read_request});
  pieces.push_back({2'000'000, read_response});
  const auto out = run(pieces, ClockQuality::per_chunk);
  const auto stream = out.stream();
  ASSERT_EQ(stream.size(), 53u);
  EXPECT_EQ(stream[48].raw, query);
  EXPECT_FALSE(stream[48].findings & finding_ambiguous_end);
  EXPECT_EQ(stream[49].reason, NoiseReason::glitch);
  EXPECT_EQ(stream[50].raw, talked_over);
  EXPECT_EQ(stream[50].request, stream[48].index);
}

// The runner-up of an end stands only where nothing refutes it. A FC08 query whose CRC ends in
// 0x00, its echo right behind it in the same read: the query could be one byte shorter with a
// glitch after it (no silence there), the echo could not, for a silence follows its 0x00: a
// glitch comes before the next frame, not before a silence.
TEST_F(GapCollector, AnEchoWhoseZeroASilenceFollowsIsNotInDoubt) {
  const auto query = hex("11 08 00 00 00 da 63 00");
  const std::vector<Piece> pieces{{20'000'000, concat({query, query})},
                                  {200'000'000, read_request},
                                  {2'000'000, read_response}};
  const auto frames = run(pieces, ClockQuality::per_chunk).frames();
  ASSERT_EQ(frames.size(), 4u);
  EXPECT_EQ(frames[0].raw, query);
  EXPECT_TRUE(frames[0].findings & finding_ambiguous_end);
  EXPECT_EQ(frames[1].raw, query);
  EXPECT_EQ(frames[1].request, frames[0].index);
  EXPECT_FALSE(frames[1].findings & finding_ambiguous_end);
}

// FC07's answer whose status equals the request's CRC low byte starts with a copy of the
// request; its last byte talked over, the copy came too soon to be the master's retry and runs
// on into a byte no frame explains: it is the answer, damaged. Read in one piece, or with the
// answer's five bytes in a read of their own (an adapter's read a frame), so that the byte
// after the copy is all there is of what follows when it is first judged.
TEST_F(GapCollector, AnAnswerThatStartsAsACopyOfItsRequestIsNotARetry) {
  const auto status = hex("07 07 42 42");  // the request; its good answer is it and a 0x00
  const auto damaged = concat({status, hex("5a")});
  const std::vector<std::vector<Piece>> readings{{{2'000'000, concat({damaged, read_request})}},
                                                 {{2'000'000, damaged}, {0, read_request}}};
  for (size_t r = 0; r < readings.size(); ++r) {
    std::vector<Piece> pieces{{20'000'000, status}};
    pieces.insert(pieces.end(), readings[r].begin(), readings[r].end());
    pieces.push_back({2'000'000, read_response});
    const auto frames = run(pieces, ClockQuality::per_chunk).frames();
    ASSERT_EQ(frames.size(), 4u) << r;
    EXPECT_EQ(frames[1].raw, damaged) << r;
    EXPECT_EQ(frames[1].role, Role::response) << r;
    EXPECT_FALSE(frames[1].check_ok) << r;
    EXPECT_EQ(frames[1].request, frames[0].index) << r;
    EXPECT_EQ(frames[2].raw, read_request) << r;
  }
  // Cut right after the copy, with a frame after it: the answer cut short while it was due, a
  // retry only long after.
  for (const int64_t after_ns : {3'000'000, 300'000'000}) {
    const std::vector<Piece> pieces{{20'000'000, status},
                                    {after_ns, concat({status, read_request})}};
    const auto frames = run(pieces, ClockQuality::per_chunk).frames();
    const bool due = after_ns < 50'000'000;
    ASSERT_EQ(frames.size(), 3u) << after_ns;
    EXPECT_EQ(frames[1].raw, status) << after_ns;
    EXPECT_EQ(frames[1].role, due ? Role::response : Role::request) << after_ns;
    EXPECT_EQ(frames[1].damage, due ? Damage::cut : Damage::none) << after_ns;
    EXPECT_EQ(frames[1].check_ok, !due) << after_ns;
    EXPECT_EQ(frames[2].raw, read_request) << after_ns;
  }
}

// A master may send its request again as soon as an answer comes damaged: FC0C's answer cut
// after 11 of its 15 bytes, then the request again, then the slave's driver's 0xFF and its
// answer, talked over. The copy is the retry and what follows it its answer, damaged, though
// the copy came too soon for a time-out and no frame follows it.
TEST_F(GapCollector, ARequestSentAgainAfterADamagedAnswerKeepsItsAnswerAfterAGlitch) {
  const auto log = hex("52 0c 3c d5");  // Get Comm Event Log of slave 82
  const auto cut = hex("52 0c 0a 9d 48 87 26 e4 1f 91 1a");
  const auto talked_over = hex("52 0c 0a eb f3 9c af 2f 0f ed 7a b3 27 2e 85");
  const std::vector<Piece> pieces{
      {20'000'000, log},          {2'000'000, cut},
      {3'000'000, log},           {2'000'000, concat({hex("ff"), talked_over})},
      {20'000'000, read_request}, {2'000'000, read_response}};
  const auto out = run(pieces, ClockQuality::per_chunk);
  const auto frames = out.frames();
  ASSERT_EQ(frames.size(), 6u);
  EXPECT_EQ(frames[1].raw, cut);
  EXPECT_EQ(frames[1].damage, Damage::cut);
  EXPECT_EQ(frames[1].request, frames[0].index);
  EXPECT_EQ(frames[2].raw, log);
  EXPECT_EQ(frames[2].role, Role::request);
  EXPECT_TRUE(frames[2].check_ok);
  EXPECT_EQ(frames[3].raw, talked_over);
  EXPECT_EQ(frames[3].role, Role::response);
  EXPECT_EQ(frames[3].request, frames[2].index);
  EXPECT_EQ(frames[4].raw, read_request);
}

// A read of 26 registers, whose answer is talked over: inside the 57 bytes it claims, eight
// pass a CRC as slave 59's answer to a write nobody asked for. They are the answer's junk;
// after the answer cut and the master's write to slave 59, they are that write's answer. (Here
// the write is framed first; where an answer is weighed inside another span's judgement, its
// own request right before it keeps it: seed 1073 of RealMasterSeeds.)
TEST_F(GapCollector, AnAnswerNobodyAwaitsInsideTheAwaitedAnswerIsItsJunk) {
  const auto read = with_crc(hex("b3 04 30 71 00 1a"));
  const auto write = with_crc(hex("3b 10 ea 4c 00 02 04 00 01 00 02"));
  const auto written = with_crc(hex("3b 10 ea 4c 00 02"));
  std::vector<uint8_t> talked_over = concat(
      {hex("b3 04 34"), std::vector<uint8_t>(25, 0x5a), written, std::vector<uint8_t>(21, 0xa5)});
  ASSERT_EQ(talked_over.size(), 57u);
  const auto out = run({{20'000'000, read},
                        {2'000'000, talked_over},
                        {60'000'000, read_request},
                        {2'000'000, read_response}},
                       ClockQuality::per_chunk);
  const auto frames = out.frames();
  ASSERT_EQ(frames.size(), 4u);
  EXPECT_EQ(frames[1].raw, talked_over);
  EXPECT_FALSE(frames[1].check_ok);
  EXPECT_EQ(frames[1].request, frames[0].index);
  EXPECT_EQ(frames[2].raw, read_request);

  const auto cut = hex("b3 04 34 5a 5a 5a 5a 5a");
  const auto answered = run({{20'000'000, read},
                             {2'000'000, concat({cut, write, written})},
                             {60'000'000, read_request},
                             {2'000'000, read_response}},
                            ClockQuality::per_chunk)
                            .frames();
  ASSERT_EQ(answered.size(), 6u);
  EXPECT_EQ(answered[1].raw, cut);
  EXPECT_EQ(answered[2].raw, write);
  EXPECT_EQ(answered[3].raw, written);
  EXPECT_EQ(answered[3].request, answered[2].index);
}

// Frames 1 and 2: the awaited answer cut a byte short, then the next request, whole.
void expect_cut_answer_then_request(const std::vector<Record>& frames,
                                    const std::vector<uint8_t>& cut,
                                    const std::vector<uint8_t>& next) {
  EXPECT_EQ(frames[1].raw, cut);
  EXPECT_EQ(frames[1].role, Role::response);
  EXPECT_EQ(frames[1].damage, Damage::cut);
  EXPECT_EQ(frames[2].raw, next);
  EXPECT_EQ(frames[2].role, Role::request);
  EXPECT_TRUE(frames[2].check_ok);
}

// A span the bytes refute is no frame in either role. FC06's echo cut one byte short, the next
// request's slave address (155) its missing CRC byte: the eight bytes read as the echo and as
// the request again, byte for byte. What follows refutes the span as the answer (a whole
// request starts at its last byte, nothing after it), and so as the master's retry too, though
// no row speaks against the retry (slave 155 does not answer, so no exchange is swallowed).
TEST_F(GapCollector, ASpanRefutedAsTheAnswerIsNoRetryEither) {
  const auto request = hex("11 06 00 01 00 03 9a 9b");
  const auto cut = hex("11 06 00 01 00 03 9a");
  const auto next = hex("9b 03 00 00 00 01 99 f0");
  const std::vector<Piece> pieces{
      {20'000'000, request}, {2'000'000, concat({cut, next})}, {200'000'000, read_request}};
  const auto frames = run(pieces, ClockQuality::per_chunk).frames();
  ASSERT_EQ(frames.size(), 4u);
  expect_cut_answer_then_request(frames, cut, next);
}

// An FC07 answer cut one byte short, and the next request's slave address (142) is its missing
// CRC byte: the bytes read as the whole answer and a request one byte short. What follows
// tells: nothing starts after the longer answer, and a whole request starts at its last byte.
// Read in one piece, in two, or with the request's first byte read apart (as modtap's pcapng
// reader reads a packet, to time its first byte), the answer is the damaged one and the
// request is whole.
TEST_F(GapCollector, AResponseCutOneByteShortGivesTheNextRequestBackItsSlaveAddress) {
  const auto request = hex("d6 07 1e 12");
  const auto cut = hex("d6 07 f7 d3");  // its answer, without the CRC's last byte 8e
  const auto next = hex("8e 07 25 d2");
  const auto answer = with_crc({0x8e, 0x07, 0x55});
  ASSERT_EQ(crc16(hex("d6 07 f7")), 0x8ed3);
  const std::vector<std::vector<Piece>> readings{
      {{2'000'000, concat({cut, next})}},
      {{2'000'000, cut}, {5'000'000, next}},
      {{2'000'000, cut}, {5'000'000, hex("8e")}, {0, hex("07 25 d2")}},
      // A timer's reads, which end wherever the bytes do: one that began before the response
      // (with a turnaround's glitch) ends right after the next request's slave address.
      {{2'000'000, concat({hex("ff"), cut, hex("8e")})}, {0, hex("07 25 d2")}},
      {{2'000'000, hex("ff d6")}, {0, hex("07 f7 d3 8e")}, {0, hex("07 25 d2")}}};
  for (size_t r = 0; r < readings.size(); ++r) {
    std::vector<Piece> pieces{{20'000'000, request}};
    pieces.insert(pieces.end(), readings[r].begin(), readings[r].end());
    pieces.push_back({2'000'000, answer});
    const auto frames = run(pieces, ClockQuality::per_chunk).frames();
    ASSERT_EQ(frames.size(), 4u) << r;
    expect_cut_answer_then_request(frames, cut, next);
    EXPECT_EQ(frames[3].request, frames[2].index);
  }
  // Its last byte read alone and nothing after it: the answer, whole, once the capture ends.
  const std::vector<Piece> last{{20'000'000, request}, {2'000'000, cut}, {5'000'000, hex("8e")}};
  const auto whole = run(last, ClockQuality::per_chunk).frames();
  ASSERT_EQ(whole.size(), 2u);
  EXPECT_EQ(whole[1].raw, concat({cut, hex("8e")}));
  EXPECT_TRUE(whole[1].check_ok);
  EXPECT_EQ(whole[1].request, whole[0].index);
}

// An exception cut before its CRC, 0073H, and the next request's driver's 0x00 glitch and
// slave address 73H complete it (fresh seed 3193): read packet by packet, as modtap reads its
// own pcapng (the glitch a packet, each packet's first byte apart), the request's first byte
// comes alone after the glitch's, and the answer waits for the bytes that tell: the request
// is whole and its answer, its echo, paired with it.
TEST_F(GapCollector, AnAnswerCutBeforeAGlitchWaitsForTheRequestReadPacketByPacket) {
  const auto request = hex("a1 01 00 eb 0b 25 92 75");
  const auto cut = hex("a1 81 03");
  const auto next = hex("73 16 94 b5 5f 38 32 2c 66 91");
  ASSERT_TRUE(rtu_crc_holds(hex("a1 81 03 00 73")));
  const std::vector<uint8_t> rest(next.begin() + 1, next.end());
  const std::vector<Piece> pieces{{20'000'000, request},  {2'000'000, hex("a1")},
                                  {0, hex("81 03")},      {2'000'000, hex("00")},
                                  {1'000'000, hex("73")}, {0, rest},
                                  {5'000'000, next},      {20'000'000, read_request}};
  const auto frames = run(pieces, ClockQuality::per_chunk).frames();
  ASSERT_EQ(frames.size(), 5u);
  EXPECT_FALSE(frames[1].check_ok);  // the glitch kept or not, as the bus's glitch odds say
  EXPECT_TRUE(std::equal(cut.begin(), cut.end(), frames[1].raw.begin()));
  EXPECT_EQ(frames[2].raw, next);
  EXPECT_TRUE(frames[2].check_ok);
  EXPECT_EQ(frames[3].request, frames[2].index);
}

// An FC17 answer cut two bytes short, and the next request, Report Server ID of slave 132
// (`84 11 a2 bc`), begins with its whole missing CRC: the bytes read as the whole answer and
// junk. What follows tells as it does for one byte: nothing starts after the longer answer,
// and a whole request starts in its CRC bytes, whose own answer follows after a glitch.
TEST_F(GapCollector, AResponseCutTwoBytesShortGivesTheNextRequestBackItsFirstBytes) {
  const auto request = hex("d8 17 00 94 00 01 00 45 00 03 06 a4 f8 f1 fa 25 68 08 b0");
  const auto cut = hex("d8 17 02 8e 37");  // its answer, without its CRC, 84 11
  const auto next = hex("84 11 a2 bc");
  const auto answer = hex("84 11 0e 0f e9 6e bb 71 d8 28 92 21 3c 93 55 ab 24 6a 40");
  ASSERT_EQ(crc16(cut), 0x1184);
  ASSERT_EQ(crc16(request), 0);
  ASSERT_EQ(crc16(answer), 0);
  const std::vector<Piece> pieces{{20'000'000, request},
                                  {2'000'000, concat({cut, next})},
                                  {5'000'000, concat({hex("00"), answer})},
                                  {20'000'000, read_request}};
  const auto frames = run(pieces, ClockQuality::per_chunk).frames();
  ASSERT_EQ(frames.size(), 5u);
  expect_cut_answer_then_request(frames, cut, next);
  EXPECT_EQ(frames[3].raw, answer);
  EXPECT_EQ(frames[3].request, frames[2].index);
}

// The pending request again, late enough for the master's retry, reads as the start of an
// answer that ends elsewhere. Shorter: an FC0F write whose CRC is 0000H, its first eight bytes
// the very answer it awaits (fresh seed 3524). Longer: an FC01 read whose third byte, 8EH,
// counts 142 bytes of coils, and the frames after it pass that answer's CRC by chance (seed
// 4088). Either way the copy is the retry, and the answer after it is its own.
TEST_F(GapCollector, ARetryIsNoAnswerThatStartsAsItAndEndsElsewhere) {
  const auto write = hex("db 0f 1d e8 00 01 01 69 00 00");
  const auto written = hex("db 0f 1d e8 00 01 01 69");
  ASSERT_TRUE(rtu_crc_holds(write));
  ASSERT_TRUE(rtu_crc_holds(written));
  const std::vector<Piece> short_pieces{
      {20'000'000, write}, {222'000'000, write}, {5'000'000, written}, {20'000'000, read_request}};
  const auto shorter = run(short_pieces, ClockQuality::per_chunk).frames();
  ASSERT_EQ(shorter.size(), 4u);
  EXPECT_EQ(shorter[1].raw, write);
  EXPECT_EQ(shorter[1].role, Role::request);
  EXPECT_EQ(shorter[2].raw, written);
  EXPECT_EQ(shorter[2].request, shorter[1].index);

  const auto read = hex("e4 01 8e 71 00 2d 91 11");
  const auto coils = with_crc(hex("e4 01 06 01 02 03 04 05 06"));
  const auto poll = with_crc(hex("0a 03 00 00 00 0a"));
  const auto registers = concat({hex("0a 03 14"), std::vector<uint8_t>(20, 0x11)});
  std::vector<uint8_t> bytes = concat({read, coils});
  for (int i = 0; i < 4; ++i) bytes = concat({bytes, poll, with_crc(registers)});
  // 151 bytes from the copy on: the last answer's data bytes 145 and 146 are made the CRC of the
  // 145 before them, and its own CRC made again.
  const uint16_t chance = crc16(std::span(bytes).first(145));
  bytes[145] = chance & 0xFF;
  bytes[146] = chance >> 8;
  const uint16_t own = crc16(std::span(bytes).subspan(bytes.size() - 25, 23));
  bytes[bytes.size() - 2] = own & 0xFF;
  bytes.back() = own >> 8;
  ASSERT_TRUE(rtu_crc_holds(std::span(bytes).first(147)));
  ASSERT_TRUE(rtu_crc_holds(std::span(bytes).last(25)));
  const std::vector<Piece> long_pieces{
      {20'000'000, read}, {224'000'000, bytes}, {20'000'000, read_request}};
  const auto longer = run(long_pieces, ClockQuality::per_chunk).frames();
  ASSERT_EQ(longer.size(), 12u);
  EXPECT_EQ(longer[1].raw, read);
  EXPECT_EQ(longer[1].role, Role::request);
  EXPECT_EQ(longer[2].raw, coils);
  EXPECT_EQ(longer[2].request, longer[1].index);
  for (const auto& frame : longer) EXPECT_TRUE(frame.check_ok);
}

// An answer cut short reads whole where the bytes after its end pass its CRC, and a request
// that starts inside it and runs past its end is what tells: nothing starts after the longer
// answer. The request may be one whose end only a search finds: an FC23 exception cut before
// its CRC's last byte, 33H, which the next request's slave address repeats, an FC08 Return
// Query Data whose echo follows (fresh seed 3157). Or it may start further in, after its
// driver's glitch: an FC0F answer cut after 3 bytes, a 0x00, and an FC17 request whose first
// four bytes and the 0x00 pass the answer's CRC, to a slave that does not answer (3495).
TEST_F(GapCollector, AnAnswerCutShortGivesBackTheRequestThatStartsInsideIt) {
  const auto fc08 = hex("33 08 00 00 24 49 57 1b 47 af 2f e2");
  const auto fc17 = hex("78 17 00 7d 00 01 03 a4 00 01 02 45 a4 7c 89");
  struct Case {
    std::vector<uint8_t> request, cut, between, next, after;
    size_t read_whole;  // the length that reads as the whole answer
  };
  const std::vector<Case> cases{
      {hex("0f 17 01 85 00 0f 01 17 00 04 08 bc 66 d0 02 06 c3 fe 87 bd 8c"),
       hex("0f 97 01 ee"),
       {},
       fc08,
       fc08,
       5},
      {hex("11 0f ee fd 00 15 03 cc a9 dd b1 1d"), hex("11 0f ee"), hex("00"), fc17, {}, 8}};
  for (const Case& c : cases) {
    ASSERT_TRUE(rtu_crc_holds(c.next));
    const auto bytes = concat({c.cut, c.between, c.next, c.after});
    ASSERT_TRUE(rtu_crc_holds(std::span(bytes).first(c.read_whole)));
    const std::vector<Piece> pieces{
        {20'000'000, c.request}, {2'000'000, bytes}, {200'000'000, read_request}};
    const auto stream = run(pieces, ClockQuality::per_chunk).stream();
    ASSERT_GE(stream.size(), 4u);
    EXPECT_EQ(stream[1].raw, c.cut);
    EXPECT_EQ(stream[1].damage, Damage::cut);
    const size_t next = c.between.empty() ? 2 : 3;
    EXPECT_EQ(stream[next].raw, c.next);
    EXPECT_EQ(stream[next].role, Role::request);
    EXPECT_TRUE(stream[next].check_ok);
  }
}

// Two FC08 queries, each with its echo, a driver's glitch between (fresh seed 5524): the 58
// bytes from the first query to the second echo pass a CRC too, and the next request confirms
// that end. A query and its echo inside a span, its end told by the copy after it, are frames
// a bus carries as much as a frame whose length rules tell its end: the span swallows them,
// and gives way.
TEST(RtuFramer, ASpanFoundBySearchGivesWayToAQueryAndItsEchoInsideIt) {
  const auto first = hex("b6 08 00 00 3e 0a 32 01 4e a5 2f 80 0f 85");
  const auto second = hex("4c 08 00 00 03 64 47 13 81 a1 5a 3a 73 47");
  const auto write = hex("39 05 72 99 00 00 02 25");
  const auto span = concat({first, hex("00"), first, hex("ff"), second, second});
  ASSERT_TRUE(rtu_crc_holds(span));
  const auto stream = analyze_untimed(concat({span, write})).stream();
  ASSERT_EQ(stream.size(), 7u);
  const std::vector<std::vector<uint8_t>> raws{first,  hex("00"), first, hex("ff"),
                                               second, second,    write};
  for (size_t i = 0; i < raws.size(); ++i) EXPECT_EQ(stream[i].raw, raws[i]) << i;
  EXPECT_EQ(stream[0].role, Role::request);
  EXPECT_EQ(stream[2].role, Role::response);
  EXPECT_EQ(stream[5].role, Role::response);
}

// FC08 Return Query Data ends where its CRC says only if something confirms it. Here a glitch
// and its exception, talked over, follow it, then the master's next request after its
// time-out: that silence bounds the junk as the end of the input would, and the request's own
// header and CRC have to do. Before, all of it up to the silence was one damaged request.
TEST_F(GapCollector, AQueryFollowedByJunkUpToASilenceIsAFrame) {
  const auto query = with_crc({0x5f, 0x08, 0x00, 0x00, 0x29, 0x73, 0xc1, 0xe6, 0xe9, 0x63});
  const auto damaged = hex("5f 88 02 a6 00");  // its exception, the CRC's last byte 13 lost
  const std::vector<Piece> pieces{{20'000'000, concat({query, hex("ff"), damaged})},
                                  {60'000'000, read_request},
                                  {2'000'000, read_response}};
  const auto out = run(pieces, ClockQuality::per_chunk);
  const auto frames = out.frames();
  ASSERT_EQ(frames.size(), 4u);
  EXPECT_EQ(frames[0].raw, query);
  EXPECT_TRUE(frames[0].check_ok);
  EXPECT_EQ(frames[0].role, Role::request);
  EXPECT_EQ(frames[1].raw, damaged);
  EXPECT_FALSE(frames[1].check_ok);
  EXPECT_EQ(frames[1].request, frames[0].index);
  EXPECT_EQ(frames[2].raw, read_request);
}

// A frame whose CRC is good before a silence keeps that reading, whatever the silence is
// followed by: FC07's retry (four bytes) and the 0x00 of the broadcast after the master's
// time-out read as the five-byte answer the pending request awaits, which the silence breaks.
TEST_F(GapCollector, AFrameEndingBeforeASilenceIsReadThereWhateverFollows) {
  const auto status = hex("61 07 69 e2");
  const auto broadcast = with_crc({0x00, 0x06, 0x00, 0x01, 0x00, 0x03});
  const std::vector<Piece> pieces{{20'000'000, read_request},
                                  {2'000'000, read_response},
                                  {20'000'000, status},
                                  {230'000'000, status},
                                  {230'000'000, broadcast}};
  const auto frames = run(pieces, ClockQuality::per_chunk).frames();
  ASSERT_EQ(frames.size(), 5u);
  EXPECT_EQ(frames[3].raw, status);
  EXPECT_TRUE(frames[3].check_ok);
  EXPECT_EQ(frames[3].role, Role::request);
  EXPECT_EQ(frames[4].raw, broadcast);
}

// A write broken off, a silence, then the next driver's glitch and a whole request: the write's
// byte count claims all of it, and a CRC that holds over the claimed length (made so here, 1
// span in 65,536 by chance) comes with the request's read. The silence inside with a good frame
// after its glitch says the write broke off there, as a frame right after the silence does;
// and the bound that keeps a reading from waiting across a silence is this same evidence.
TEST_F(GapCollector, ASpanBrokeOffAtASilenceThatAGlitchAndAFrameFollow) {
  const auto broken_off = hex("01 10 00 01 00 05 0a 7e");
  const auto claimed = with_crc(concat({broken_off, hex("00"), read_request}));
  const std::vector<uint8_t> rest(claimed.begin() + 8, claimed.end());
  const auto stream =
      run({{60'000'000, broken_off}, {60'000'000, rest}}, ClockQuality::per_chunk).stream();
  ASSERT_EQ(stream.size(), 4u);
  EXPECT_EQ(stream[0].raw, broken_off);
  EXPECT_FALSE(stream[0].check_ok);  // eight bytes, read as a FC16 answer with a bad check
  EXPECT_EQ(stream[1].reason, NoiseReason::glitch);
  EXPECT_EQ(stream[2].raw, read_request);
  EXPECT_TRUE(stream[2].check_ok);
  EXPECT_EQ(stream[3].type, Record::Type::noise);
}

// FC07's answer whose first four bytes are its request again, its status talked over: inside
// the answer's span, "07 12 ..." starts a vendor code whose end only a CRC search could tell.
// It cannot stand there, so it does not hold the damaged answer and the next request back
// until 256 bytes have come.
TEST_F(GapCollector, AVendorStartInsideTheAwaitedAnswerHoldsNothingBack) {
  const auto request = hex("c4 07 12 b2");
  const std::vector<Piece> pieces{{20'000'000, request},
                                  {2'000'000, concat({request, hex("0f"), read_request})}};
  const auto frames = run(pieces, ClockQuality::per_chunk, false).frames();
  ASSERT_EQ(frames.size(), 3u);
  EXPECT_EQ(frames[1].raw, concat({request, hex("0f")}));
  EXPECT_EQ(frames[1].role, Role::response);
  EXPECT_FALSE(frames[1].check_ok);
  EXPECT_EQ(frames[2].raw, read_request);
}

// An exception talked over, "32 81 03 14 5b": from its second byte on, its bytes, the next
// request and part of that request's answer read as a 25-byte FC03 answer of slave 129 whose
// CRC holds (here made to, with two of the answer's data bytes; 1 start in 65,536 on a bus).
// Nobody asked slave 129, and the reading swallows a request and answer whose length rules
// and CRC agree: it is refused, and the exception is the damaged answer.
TEST_F(GapCollector, AnAnswerNobodyAwaitsSwallowsNoGoodFrame) {
  const auto request = with_crc(hex("32 01 00 00 00 10"));
  const auto damaged = hex("32 81 03 14 5b");
  const auto next = with_crc(hex("07 03 00 00 00 0a"));
  std::vector<uint8_t> data(20, 0x11);
  std::vector<uint8_t> false_frame =
      concat({std::vector<uint8_t>(damaged.begin() + 1, damaged.end()), next, hex("07 03 14"),
              std::vector<uint8_t>(data.begin(), data.begin() + 8)});
  const uint16_t crc = crc16(false_frame);
  data[8] = static_cast<uint8_t>(crc & 0xff);
  data[9] = static_cast<uint8_t>(crc >> 8);
  const auto answer = with_crc(concat({hex("07 03 14"), data}));
  ASSERT_NE(crc16(hex("32 81 03")), 0x5b14);
  ASSERT_EQ(crc16(concat({std::vector<uint8_t>(damaged.begin() + 1, damaged.end()), next,
                          std::vector<uint8_t>(answer.begin(), answer.begin() + 13)})),
            0);
  const std::vector<Piece> pieces{{20'000'000, request},
                                  {3'000'000, concat({damaged, next, answer})},
                                  {20'000'000, read_request}};
  const auto frames = run(pieces, ClockQuality::per_chunk).frames();
  ASSERT_EQ(frames.size(), 5u);
  EXPECT_EQ(frames[1].raw, damaged);
  EXPECT_EQ(frames[1].role, Role::response);
  EXPECT_FALSE(frames[1].check_ok);
  EXPECT_EQ(frames[1].request, frames[0].index);
  EXPECT_EQ(frames[2].raw, next);
  EXPECT_EQ(frames[3].raw, answer);
  EXPECT_EQ(frames[3].request, frames[2].index);
}

// A read of 32 coils, and its answer talked over: "37 01 04" as due, then junk whose first
// eight bytes pass a CRC as a read of 0xFFC9 coils (here made to). Where the answer was due,
// too soon for the master's next request, they are the answer, damaged; long after, with
// nothing in between, the same bytes are the master's request (over the limits).
TEST_F(GapCollector, JunkThatBeginsAsTheAwaitedAnswerIsNotARequestWhileItIsDue) {
  const auto request = with_crc(hex("37 01 df 2f 00 20"));
  const auto junk = concat({with_crc(hex("37 01 04 69 ff c9")), hex("06")});
  ASSERT_NE(crc16(junk), 0);  // no good answer of 4 bytes of coils
  for (const int64_t after_ns : {3'000'000, 300'000'000}) {
    const std::vector<Piece> pieces{
        {20'000'000, request}, {after_ns, junk}, {20'000'000, read_request}};
    const auto frames = run(pieces, ClockQuality::per_chunk).frames();
    const bool due = after_ns < 50'000'000;
    ASSERT_EQ(frames.size(), 3u) << after_ns;
    EXPECT_EQ(frames[1].raw.size(), due ? junk.size() : junk.size() - 1) << after_ns;
    EXPECT_EQ(frames[1].role, due ? Role::response : Role::request) << after_ns;
    EXPECT_EQ(frames[1].check_ok, !due) << after_ns;
    EXPECT_EQ(frames.back().raw, read_request) << after_ns;
  }
}

// Slave 3's answer to FC0C after its driver's 0xFF, whose first bytes after the glitch pass a
// CRC as a read for slave 255 (`ff 03 0c 15 de 10 1a ec`): a glitch with the awaited answer's
// slave and function code after it, where the answer is due, starts no request.
TEST_F(GapCollector, AGlitchBeforeTheAwaitedAnswerStartsNoRequest) {
  const auto request = hex("03 0c 01 45");
  const auto answer =
      hex("03 0c 15 de 10 1a ec 41 31 c6 88 17 63 bf 1d 11 67 a0 45 dd cb a7 a3 25 c5 fe");
  ASSERT_EQ(crc16(answer), 0);
  ASSERT_EQ(crc16(concat({hex("ff"), std::vector<uint8_t>(answer.begin(), answer.begin() + 7)})),
            0);
  expect_glitch_then_answer(request, 0xff, answer);
}

// Slave 144's answer to FC10 after its driver's 0xFF, whose first bytes after the glitch pass a
// CRC as an exception from station 255 (`ff 90 10` and a CRC, the address chosen so): read
// before the answer's last bytes have come, the exception waits for the frame it may swallow,
// a reserved address's, which refutes it once they come (swallows-known-frame).
TEST_F(GapCollector, AReservedAddressWaitsForTheFrameItMaySwallow) {
  const auto exception = with_crc(hex("ff 90 10"));
  const auto address = std::vector<uint8_t>(exception.end() - 2, exception.end());
  const auto request = with_crc(concat({hex("90 10"), address, hex("00 02 04 00 01 00 02")}));
  const auto answer = with_crc(concat({hex("90 10"), address, hex("00 02")}));
  expect_glitch_then_answer(request, 0xff, answer);
}

// Slave 0x11's answer to a read of five registers cut after seven bytes, then the master's
// next request, to slave 0x22: the cut answer takes the CRC back to its start value (the data
// chosen so), so the fifteen bytes the answer's byte count claims pass its CRC (fresh seeds
// 5343 and 5899). The request's answer after it, or the master's retry after its time-out and
// a glitch, says the request was sent: the answer is cut, and the request a frame of its own.
// Read a frame a read, all in one read, and with the retry after a silence.
TEST_F(GapCollector, ARequestWhoseAnswerOrRetryFollowsIsNoPartOfTheAnswerBefore) {
  const auto read = with_crc(hex("11 03 00 00 00 05"));
  const auto cut = hex("11 03 0a 12 34 a2 27");
  ASSERT_EQ(crc16(cut), 0xFFFF);
  const auto request = with_crc(hex("22 03 00 10 00 01"));
  const auto answer = with_crc(hex("22 03 02 00 2a"));
  const std::vector<std::vector<Piece>> buses{
      {{20'000'000, read}, {3'000'000, cut}, {5'000'000, request}, {3'000'000, answer}},
      {{20'000'000, read}, {3'000'000, concat({cut, request, answer})}},
      {{20'000'000, read},
       {3'000'000, cut},
       {5'000'000, request},
       {300'000'000, concat({hex("ff"), request})},
       {3'000'000, answer}}};
  for (size_t bus = 0; bus < buses.size(); ++bus) {
    const auto stream = run(buses[bus], ClockQuality::per_chunk).stream();
    ASSERT_EQ(stream.size(), bus == 2 ? 6u : 4u) << bus;
    EXPECT_EQ(stream[1].raw, cut) << bus;
    EXPECT_EQ(stream[1].damage, Damage::cut) << bus;
    EXPECT_EQ(stream[1].request, stream[0].index) << bus;
    EXPECT_EQ(stream[2].raw, request) << bus;
    EXPECT_EQ(stream.back().raw, answer) << bus;
    EXPECT_EQ(stream.back().request, stream[stream.size() - 2].index) << bus;
  }
}

// The same with the driver's other glitch, 0x00: slave 6's answer to a read after it, whose
// first bytes after the glitch pass a CRC as a broadcast write of a register (`00 06 03 04 ...`,
// the data chosen so). A broadcast is no reading in the other role, and is refused all the same.
TEST_F(GapCollector, AZeroGlitchBeforeTheAwaitedAnswerStartsNoBroadcast) {
  const auto request = with_crc(hex("06 03 00 00 00 02"));
  const auto broadcast = with_crc(hex("00 06 03 04 12 34"));
  const auto answer = with_crc(
      concat({hex("06 03 04 12 34"), std::vector<uint8_t>(broadcast.end() - 2, broadcast.end())}));
  expect_glitch_then_answer(request, 0x00, answer);
}

// A write of a file record, whose echo is talked over at its end: from its fifth byte on, the
// echo's bytes pass a CRC as a broadcast write of a coil (`00 05 05 d4 00 05 4c ec`, the
// request's file, record, length and first data bytes, chosen so). Each of them is the byte
// the request says its echo has there: they are the echo's, and the echo is one damaged frame.
TEST_F(GapCollector, BytesTheRequestPredictsInsideItsAnswerAreTheAnswers) {
  const auto request = with_crc(hex("da 15 11 06 00 05 05 d4 00 05 4c ec 11 22 33 44 55 66 77 88"));
  ASSERT_EQ(crc16(hex("00 05 05 d4 00 05 4c ec")), 0);
  auto echo = request;
  for (size_t i = 14; i < echo.size(); ++i) echo[i] ^= 0x5a;  // talked over
  const std::vector<Piece> pieces{
      {20'000'000, request}, {3'000'000, echo}, {20'000'000, read_request}};
  const auto stream = run(pieces, ClockQuality::per_chunk).stream();
  ASSERT_EQ(stream.size(), 3u);
  EXPECT_EQ(stream[1].raw, echo);
  EXPECT_EQ(stream[1].role, Role::response);
  EXPECT_FALSE(stream[1].check_ok);
  EXPECT_EQ(stream[1].request, stream[0].index);
  EXPECT_EQ(stream[2].raw, read_request);
}

// FC08 Return Query Data, whose end only its CRC tells, holds bytes that pass a CRC as a frame
// of vendor code CDH with an exception no standard names: "52 cd d5 45 1e". A frame a bus
// would not carry does not count against the query that holds it, nor against its echo.
TEST_F(GapCollector, ANonStandardFrameInsideAQueryDoesNotCutIt) {
  const auto query = hex("ba 08 00 00 58 a9 54 52 cd d5 45 1e");
  ASSERT_EQ(crc16(query), 0);
  ASSERT_EQ(crc16(hex("52 cd d5 45 1e")), 0);
  const std::vector<Piece> pieces{
      {20'000'000, query}, {3'000'000, query}, {20'000'000, read_request}};
  const auto frames = run(pieces, ClockQuality::per_chunk).frames();
  ASSERT_EQ(frames.size(), 3u);
  EXPECT_EQ(frames[0].raw, query);
  EXPECT_EQ(frames[0].role, Role::request);
  EXPECT_EQ(frames[1].raw, query);
  EXPECT_EQ(frames[1].role, Role::response);
  EXPECT_EQ(frames[1].request, frames[0].index);
  EXPECT_EQ(frames[2].raw, read_request);
}

// A master whose time-out is shorter than modtap's retry threshold (50 ms with no turnaround
// learned) sends its retry, or its next write of the same block, 30 ms after a silent slave.
// A read at 0400H of 2 registers begins as its own answer would (byte count 04), and a write
// of new values as its echo would: each stays the master's request, and the answer after it
// answers it.
TEST_F(GapCollector, AQuickRetryOrNextWriteAfterASilentSlaveStaysARequest) {
  const auto read = with_crc(hex("01 03 04 00 00 02"));
  const auto read_answer = with_crc(hex("01 03 04 00 0a 00 0b"));
  const auto write = with_crc(hex("01 10 00 05 00 02 04 00 0a 01 02"));
  const auto next_write = with_crc(hex("01 10 00 05 00 02 04 00 0b 01 03"));
  const auto write_echo = with_crc(hex("01 10 00 05 00 02"));
  const std::vector<std::array<std::vector<uint8_t>, 3>> cases{{read, read, read_answer},
                                                               {write, next_write, write_echo}};
  for (size_t c = 0; c < cases.size(); ++c) {
    const auto& [first, second, answer] = cases[c];
    const std::vector<Piece> pieces{{20'000'000, first}, {30'000'000, second}, {3'000'000, answer}};
    const auto frames = run(pieces, ClockQuality::per_chunk).frames();
    ASSERT_EQ(frames.size(), 3u) << c;
    EXPECT_EQ(frames[1].raw, second) << c;
    EXPECT_EQ(frames[1].role, Role::request) << c;
    EXPECT_TRUE(frames[1].check_ok) << c;
    EXPECT_EQ(frames[2].raw, answer) << c;
    EXPECT_EQ(frames[2].request, frames[1].index) << c;
  }
}

// The bus's glitches against a frame's bytes by chance. A 0x00 after a frame whose CRC holds
// with it is a glitch only where 0x00 glitches come with more than 1 frame in 16: odds of 16
// over a CRC ending in 0x00 (1 in 256), once 16 frames have shown it. A damaged answer's last
// 0x00 or 0xFF is a glitch where glitches come with more than 1 frame in 128: even odds with a
// data byte being one (2 in 256). Before 128 frames with no glitch, the bus is not known.
TEST(GlitchOdds, EachReadingMustClearItsOwnMargin) {
  GlitchOdds odds;
  EXPECT_TRUE(odds.unknown());
  for (int i = 0; i < 15; ++i) odds.frame();
  odds.glitch(0x00);
  odds.glitch(0x00);
  EXPECT_FALSE(odds.zero_glitch_likelier()) << "15 frames are too few to tell";
  EXPECT_FALSE(odds.unknown());
  for (int i = 15; i < 32; ++i) odds.frame();
  EXPECT_FALSE(odds.zero_glitch_likelier()) << "2 in 32 is 1 in 16: no more than the margin";
  odds.glitch(0xFF);
  EXPECT_FALSE(odds.zero_glitch_likelier()) << "a 0xFF glitch says nothing of a trailing 0x00";
  odds.glitch(0x00);
  EXPECT_TRUE(odds.zero_glitch_likelier()) << "3 in 32";

  GlitchOdds trailing;
  for (int i = 0; i < 128; ++i) trailing.frame();
  EXPECT_FALSE(trailing.unknown()) << "128 frames without a glitch tell";
  trailing.glitch(0xFF);
  EXPECT_FALSE(trailing.trailing_glitch_likelier()) << "1 in 128: even, no more";
  trailing.glitch(0x00);
  EXPECT_TRUE(trailing.trailing_glitch_likelier()) << "2 in 128";
}

// A 0x00 or 0xFF at the edge of a piece: the reading with more bits wins, the bus's habit breaks
// a tie, and the margin is the evidence's alone, a quiet bus's glitch no runner-up at all.
TEST(EdgeByte, TheEvidenceDecidesAndTheBusHabitOnlyBreaksATie) {
  struct Case {
    GlitchHabit habit;
    std::vector<std::pair<Feature, bool>> features;  // a feature, and whether for the glitch
    bool glitch;
    RunnerUp runner_up;
    bool stands;
  };
  const std::vector<Case> cases = {
      {GlitchHabit::glitchy, {}, true, RunnerUp::keeps_byte, true},
      {GlitchHabit::unknown, {}, false, RunnerUp::glitch_byte, true},
      {GlitchHabit::quiet, {}, false, RunnerUp::none, false},
      {GlitchHabit::quiet, {{Feature::byte_ruled_out, true}}, true, RunnerUp::keeps_byte, false},
      {GlitchHabit::glitchy,
       {{Feature::predicted_byte, false}},
       false,
       RunnerUp::glitch_byte,
       true},
      {GlitchHabit::glitchy,
       {{Feature::silence_after, false}},
       false,
       RunnerUp::glitch_byte,
       false},
      {GlitchHabit::unknown,
       {{Feature::byte_ruled_out, true}, {Feature::sent_straight_on, false}},
       true,
       RunnerUp::keeps_byte,
       false},
      {GlitchHabit::glitchy,
       {{Feature::awaited_header, true}, {Feature::awaited_header, false}},
       true,
       RunnerUp::keeps_byte,
       true},
  };
  for (size_t i = 0; i < cases.size(); ++i) {
    const Case& c = cases[i];
    EdgeByte edge{EdgeSide::last, 0, 0xFF, c.habit};
    for (const auto& [feature, for_glitch] : c.features) edge.weigh(feature, true, for_glitch);
    edge.weigh(Feature::second_glitch, false,
               false);  // a feature that does not hold counts nothing
    EXPECT_EQ(edge.glitch(), c.glitch) << i;
    EXPECT_EQ(edge.margin().runner_up, c.runner_up) << i;
    EXPECT_EQ(edge.margin().stands(), c.stands) << i;
  }
}

}  // namespace
}  // namespace modtap
