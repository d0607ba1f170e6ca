// -b: a capture written as a ring of files, as dumpcap writes one. A new file begins when the
// current one spans so long or holds so much; once there are more files than asked for, the
// oldest goes. Files are named as dumpcap names them, PREFIX_NNNNN_YYYYmmddHHMMSS.EXT, after
// the local time of their first record (capture time for a file read, wall time on a port).
#pragma once

#include <cstdint>
#include <deque>
#include <optional>
#include <string>

namespace modtap::captures {

struct RingLimits {
  std::optional<int64_t> duration_ns;      // -b duration:S
  std::optional<uint64_t> filesize_bytes;  // -b filesize:KB
  std::optional<uint64_t> files;           // -b files:N: how many to keep
  bool rotates() const { return duration_ns || filesize_bytes; }
};

// dumpcap's name for file `number` (from 1) begun at t_ns: "out.pcapng" gives
// "out_00001_20261123093000.pcapng".
std::string ring_file_name(const std::string& path, uint64_t number, int64_t t_ns);

class FileRing {
 public:
  FileRing(std::string path, RingLimits limits);

  // Whether a record at t_ns begins a new file, the current one holding `bytes`. The first
  // record always does; without duration or filesize, no later one.
  bool due(int64_t t_ns, uint64_t bytes) const { return past(t_ns, bytes, 1); }
  // Past twice the limits: where a file that waits for a better moment must turn anyway.
  bool overdue(int64_t t_ns, uint64_t bytes) const { return past(t_ns, bytes, 2); }
  // The next file's name; past `files`, the oldest file is removed (std::runtime_error if it
  // cannot be). Without duration or filesize, the one file is the path itself.
  std::string begin(int64_t t_ns);
  // The same, named after the wall clock: a run that saw no record still leaves a file.
  std::string begin_now();
  uint64_t files_begun() const { return number_; }

 private:
  bool past(int64_t t_ns, uint64_t bytes, int factor) const;

  std::string path_;
  RingLimits limits_;
  uint64_t number_ = 0;
  int64_t started_ns_ = 0;
  std::deque<std::string> kept_;
};

}  // namespace modtap::captures
