#include "output/model_draft.hpp"

#include <filesystem>
#include <utility>

#include "captures/output_file.hpp"
#include "decoder/protocol/function_codes.hpp"
#include "output/render.hpp"

namespace modtap::output {
namespace {

std::string seconds_text(int64_t ns) {
  return fmt::format("{:.3f}", static_cast<double>(ns) / 1e9);
}
std::string milliseconds_text(int64_t ns) {
  return fmt::format("{:.1f}", static_cast<double>(ns) / 1e6);
}

std::string span_of(const RegisterReading& r) {
  if (r.words == 1) return fmt::format("{:04X}H", r.address);
  return fmt::format("{:04X}H-{:04X}H", r.address, r.address + r.words - 1);
}

// The reading in a few words: "f32, low word first", "u16 counter", "enum".
std::string reading_text(const RegisterReading& r) {
  std::string text(to_string(r.type));
  if (r.words == 2)
    text += r.order == WordOrder::high_first ? ", high word first" : ", low word first";
  if (r.kind != ReadingKind::number && r.kind != ReadingKind::text)
    text += fmt::format(" ({})", to_string(r.kind));
  return text;
}

std::string values_text(const RegisterReading& r) {
  if (r.kind == ReadingKind::text || r.kind == ReadingKind::bit_field) return "";
  const std::string unit = r.unit.empty() ? "" : " " + r.unit;
  if (r.low == r.high) return fmt::format("{:g}{}", r.low, unit);
  return fmt::format("{:g} to {:g}{}", r.low, r.high, unit);
}

std::string register_name(const RegisterReading& r) {
  const std::string_view table = r.table == Table::input ? "ir" : "hr";  // as Modbus tools say
  if (!r.quantity.empty()) return fmt::format("{}_{}_{:04x}", r.quantity, table, r.address);
  return fmt::format("{}_{:04x}", table, r.address);
}

std::string block_text(const BlockKey& block) {
  const std::string registers = block.count == 1
                                    ? fmt::format("{:04X}H", block.first)
                                    : fmt::format("{:04X}H-{:04X}H ({} registers)", block.first,
                                                  block.first + block.count - 1, block.count);
  return fmt::format("FC{:02X} {} {}", block.function, function_name(block.function),
                     block.count ? registers : "");
}

void write_blocks(Output& out, const SlaveDraft& draft) {
  out.print("  blocks:\n");
  for (const PolledBlock& polled : draft.blocks) {
    const BlockTimes& t = polled.times;
    out.print("    {}: {}, {} answered", block_text(polled.block),
              counted(t.requests, "request", "requests"), t.answered);
    if (const auto period = t.period_ns())
      out.print(", every {} s (gaps {} to {} s)", seconds_text(*period), seconds_text(t.min_gap_ns),
                seconds_text(t.max_gap_ns));
    out.print("\n");
  }
}

void write_registers(Output& out, const SlaveDraft& draft) {
  if (draft.registers.empty()) return;
  out.print("  registers:\n");
  for (const RegisterReading& r : draft.registers) {
    out.print("    {} {:<11} {:<32} {:<26} {} confidence: {}",
              fmt::format("{:<7}", to_string(r.table)), span_of(r), reading_text(r), values_text(r),
              to_string(r.confidence), r.why);
    if (!r.quantity.empty()) out.print("; likely a {}", r.quantity);
    if (!r.runner_up.empty()) out.print("; runner-up: {}", r.runner_up);
    if (r.writes && !r.write_only)
      out.print("; the master wrote it {}", counted(r.writes, "time", "times"));
    out.print("\n");
  }
}

}  // namespace

void write_discovery_summary(Output& out, const std::vector<SlaveDraft>& drafts,
                             const PollingProgram& program) {
  for (const SlaveDraft& draft : drafts) {
    out.print("slave {}\n", draft.slave);
    write_blocks(out, draft);
    write_registers(out, draft);
    if (!draft.too_few_samples.empty()) {
      out.print("  read fewer than {} times, too few to tell (a longer capture will):",
                RegisterDiscovery::min_samples);
      const char* separator = " ";
      for (const auto& [table, address] : draft.too_few_samples)
        out.print("{}{} {:04X}H", std::exchange(separator, ", "), to_string(table), address);
      out.print("\n");
    }
  }
  if (program.cycle.empty()) {
    out.print("polling program: no cycle of requests repeats in the first {}\n",
              RegisterDiscovery::program_window);
    return;
  }
  out.print("polling program: {} a cycle ({} of the first {} cycles)",
            counted(program.cycle.size(), "request", "requests"), program.cycles_seen,
            program.cycles_all);
  if (program.period_ns)
    out.print(", every {} s (jitter {} ms)", seconds_text(*program.period_ns),
              milliseconds_text(program.jitter_ns));
  out.print("\n");
  for (const BlockKey& block : program.cycle)
    out.print("  slave {} {}\n", block.slave, block_text(block));
}

std::string model_draft(const SlaveDraft& draft) {
  Output out;
  out.print(
      "# Slave {}, drafted by modtap discover from the values its master read: each register's\n"
      "# reading, with its evidence and confidence, in the comment above it. Rename, scale and\n"
      "# check against the device's manual where there is one.\n",
      draft.slave);
  out.print(
      "model: slave-{}\ntitle: Slave {} (drafted from the traffic)\nsource: modtap discover\n",
      draft.slave, draft.slave);
  if (draft.registers.empty()) return fmt::to_string(out.buffer());
  out.print("registers:\n");
  for (const RegisterReading& r : draft.registers) {
    out.print("  # {}: {}, confidence {} ({})", reading_text(r), r.why, to_string(r.confidence),
              counted(r.samples, "value", "values"));
    if (!r.runner_up.empty()) out.print("; runner-up: {}", r.runner_up);
    out.print("\n  - {{address: 0x{:04X}, table: {}, name: {}, type: {}", r.address,
              to_string(r.table), register_name(r), to_string(r.type));
    if (r.words == 2) out.print(", order: {}", to_string(r.order));
    if (r.type == ValueType::string) out.print(", words: {}", r.words);
    if (r.scale != 1.0) out.print(", scale: {:g}", r.scale);
    if (!r.unit.empty()) out.print(", unit: {}", r.unit);
    if (r.write_only) out.print(", access: W");
    out.print("}}\n");
  }
  return fmt::to_string(out.buffer());
}

std::vector<std::string> write_model_drafts(const std::string& dir,
                                            const std::vector<SlaveDraft>& drafts) {
  std::error_code error;
  std::filesystem::create_directories(dir, error);
  if (error) throw captures::WriteError(dir, error.value());
  std::vector<std::string> paths;
  for (const SlaveDraft& draft : drafts) {
    const std::string path =
        (std::filesystem::path(dir) / fmt::format("slave-{}.yaml", draft.slave)).string();
    captures::OutputFile file(path);
    file.write(model_draft(draft));
    file.close();
    paths.push_back(path);
  }
  return paths;
}

}  // namespace modtap::output
