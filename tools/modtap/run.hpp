// The two runs a pipeline makes: a capture read through, and ports listened to until stopped.
#pragma once

#include <CLI/CLI.hpp>

#include "captures/file_ring.hpp"
#include "tools/modtap/capture_conditions.hpp"
#include "tools/modtap/pipeline.hpp"

namespace modtap::tools {

// Reads the capture `o.read_file` to its end (or a -c, -a condition). Returns the exit status;
// throws on a capture that cannot be read.
int read_capture(const RunOptions& o, const Autostop& autostop, const captures::RingLimits& ring);
// Listens on `o.interfaces` until a signal, -c or -a stops it. Returns the exit status.
int listen(const RunOptions& o, const Autostop& autostop, const captures::RingLimits& ring);

// The serial line's settings and the device model, as options of `app` with their checks:
// the same for modtap and for the extcap.
void add_line_options(CLI::App& app, RunOptions& o);

}  // namespace modtap::tools
