#include "decoder/protocol/findings.hpp"

namespace modtap {

namespace {

constexpr FindingInfo registry[] = {
    // The frame's own, in Finding bit order.
    {"bad-check", Severity::error, "the CRC or LRC is wrong"},
    {"broadcast", Severity::note, "sent to slave 0: every slave acts, none answers"},
    {"illegal-broadcast", Severity::warning, "a read sent to slave 0, which no slave may answer"},
    {"unsolicited", Severity::warning, "a response with no request waiting for it"},
    {"length-mismatch", Severity::error, "a response whose content does not fit its request"},
    {"echo-mismatch", Severity::error, "an echo response that differs from its request"},
    {"fast-turnaround", Severity::warning, "the slave answered before 3.5 characters of silence"},
    {"retry", Severity::warning, "the request that just went unanswered, sent again"},
    {"quantity-out-of-spec", Severity::warning,
     "a quantity of 0 or over the standard's limit (2000 coils, 125 registers read, 123 written)"},
    {"byte-count-mismatch", Severity::warning, "a byte count that disagrees with its quantity"},
    {"value-out-of-spec", Severity::warning,
     "FC05 with a value other than FF00H or 0000H, FC08 with data its sub-function does not allow"},
    {"ambiguous-echo", Severity::note,
     "an echo taken for the response that could have been the master's retry"},
    {"short-gap", Severity::warning,
     "a request that began less than 3.5 characters after the frame before it"},
    {"late-response", Severity::warning,
     "the response to a request that had already timed out: the slave is slower than the master "
     "waits"},
    {"exception-storm", Severity::warning,
     "the same exception from the same slave, five or more answers in a row"},
    {"answers-again", Severity::warning,
     "a slave's first answer after three or more time-outs in a row: it was gone, and is back"},
    {"poll-jitter", Severity::note,
     "a request to a slave far (by half or more) from its usual poll interval: the master's "
     "cycle stalled or hurried"},
    {"gap-in-frame", Severity::warning,
     "a silence longer than 1.5 characters between two bytes of one frame, which the standard "
     "forbids: a strict slave drops the frame"},
    {"garbage-after-request", Severity::warning,
     "bytes that are no answer where a request's answer was awaited (noise, or a frame with a "
     "bad check from another slave or function): two devices talking at once, a slave at "
     "another baud rate or parity, or an answer garbled on the way"},
    {"ambiguous-end", Severity::note,
     "a damaged response whose last byte could as well be the next frame's turnaround glitch: "
     "the clock cannot see the quiet line a glitch comes after, so the frame may be one byte "
     "longer or shorter than shown"},
    {"after-other-master", Severity::note,
     "the answer to a request another master's request cut in on, paired with it after that "
     "exchange: its latency holds the other exchange, and the statistics leave it out"},
    // The device model's, in RuleKind order.
    {"reserved-write", Severity::warning, "a write to a register the manual says not to write"},
    {"read-only-write", Severity::warning, "a write to a register the device only reports"},
    {"write-only-read", Severity::warning, "a read of a write-only register"},
    {"closed-group", Severity::warning, "an access to a parameter group the device keeps closed"},
    {"too-many-words", Severity::warning, "more registers in one request than the model allows"},
    {"crosses-group", Severity::warning, "one access that spans two parameter groups"},
    {"out-of-range", Severity::warning, "a value outside the register's range"},
    {"not-in-enum", Severity::warning, "a value none of the register's named values has"},
    {"station-out-of-range", Severity::warning, "a slave address the device cannot be set to"},
    {"unmapped-register", Severity::warning, "an address in none of the model's tables"},
    {"too-many-retries", Severity::warning,
     "a request sent again more often than the model's masters do"},
    {"early-response", Severity::warning,
     "an answer sooner after its request than the model's manual says the device answers: "
     "another device answered, or the slave is not the model it is read as"},
    {"reserved-address", Severity::warning,
     "a slave address from 248 to 255, which Modbus reserves"},
    {"exception", Severity::note, "an exception response, with the model's meaning of its code"},
    {"identified", Severity::note, "the device's identification, as the model reads it"},
    {"device-fault", Severity::error, "the device reports a fault in its fault register"},
};
static_assert(std::size(registry) == frame_finding_count + rule_kind_count);

}  // namespace

std::span<const FindingInfo> finding_registry() {
  return registry;
}

std::span<const FindingInfo> frame_findings() {
  return finding_registry().first(frame_finding_count);
}

const FindingInfo& finding_info(RuleKind kind) {
  return registry[finding_slot(kind)];
}

std::string_view to_string(RuleKind kind) {
  return finding_info(kind).name;
}

}  // namespace modtap
