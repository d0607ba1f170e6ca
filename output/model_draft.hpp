// What modtap discover writes: a readable summary of each slave's blocks, register readings and
// the master's polling program, and a draft device model per slave in modtap's own YAML
// (docs/discover.md), each register's evidence in a comment.
#pragma once

#include <string>
#include <vector>

#include "decoder/analysis/register_discovery.hpp"
#include "output/output.hpp"

namespace modtap::output {

void write_discovery_summary(Output& out, const std::vector<SlaveDraft>& drafts,
                             const PollingProgram& program);

// The draft model of one slave, named `slave-N`, as YAML text.
std::string model_draft(const SlaveDraft& draft);

// Writes DIR/slave-N.yaml for each slave; returns the paths. A failed write throws
// captures::WriteError naming the file.
std::vector<std::string> write_model_drafts(const std::string& dir,
                                            const std::vector<SlaveDraft>& drafts);

}  // namespace modtap::output
