#include "output/csv_sink.hpp"

#include <algorithm>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "decoder/models/register_meaning.hpp"

namespace modtap::output {
namespace {

// Slave 5's answer to a read of register 0 (value 7), read through the generic model.
struct Answer {
  const uint8_t request_pdu[5] = {0x03, 0x00, 0x00, 0x00, 0x01};
  const uint8_t adu[7] = {0x05, 0x03, 0x02, 0x00, 0x07, 0x00, 0x00};
  DeviceModel generic;
  Meaning meaning;
  Frame frame;

  Answer() {
    frame.adu = adu;
    frame.request_pdu = request_pdu;
    frame.role = Role::response;
    frame.check_ok = true;
    frame.request = 0;
    frame.request_slave = 5;
    interpret(generic, frame, meaning);
    frame.meaning = &meaning;
  }
};

size_t rows(Output& out) {
  const std::string text(out.buffer().data(), out.buffer().size());
  return static_cast<size_t>(std::count(text.begin(), text.end(), '\n')) - 1;  // the header
}

// A slave that may yet identify itself holds its rows only until its answers show it does not:
// a master reads a device's identification with its first requests.
TEST(CsvSink, ASlaveThatDoesNotIdentifyItselfHoldsItsRowsForItsFirstAnswersOnly) {
  Output out;
  CsvSink sink(out, {}, TimeFormat::relative);
  sink.hold_until_identified([](uint8_t) { return true; });
  Answer answer;
  for (unsigned i = 1; i < CsvSink::answers_to_identify; ++i) {
    answer.frame.t_ns = i;
    sink.on_frame(answer.frame);
  }
  EXPECT_EQ(rows(out), 0u);
  sink.on_frame(answer.frame);
  EXPECT_EQ(rows(out), CsvSink::answers_to_identify);
}

// The rows after a held one wait behind it, in time order, and no more than the hold's room.
TEST(CsvSink, RowsWaitBehindAHeldOneUpToTheHoldsRoom) {
  Output out;
  CsvSink sink(out, {}, TimeFormat::relative);
  sink.hold_until_identified([](uint8_t slave) { return slave == 5; });
  Answer held;
  sink.on_frame(held.frame);
  Answer other;
  static const uint8_t six[] = {0x06, 0x03, 0x02, 0x00, 0x08, 0x00, 0x00};
  other.frame.adu = six;
  other.frame.request_slave = 6;
  for (size_t i = 0; i < CsvSink::max_held - 1; ++i) sink.on_frame(other.frame);
  EXPECT_EQ(rows(out), 0u);
  sink.on_frame(other.frame);
  EXPECT_EQ(rows(out), CsvSink::max_held + 1);
  const std::string text(out.buffer().data(), out.buffer().size());
  EXPECT_EQ(text.substr(text.find('\n') + 1, 18), "0.000000,5,0000H,,");
  sink.finish();
}

}  // namespace
}  // namespace modtap::output
