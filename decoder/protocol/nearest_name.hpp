// The name a typo meant: the candidate fewest single-character edits away (Levenshtein's
// distance), when it is near enough to be a slip and not another name. Error messages of the
// command line, the filter and the model catalog say "did you mean ...?" with it.
#pragma once

#include <algorithm>
#include <cstddef>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace modtap {

inline size_t edit_distance(std::string_view a, std::string_view b) {
  std::vector<size_t> row(b.size() + 1);
  for (size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (size_t i = 1; i <= a.size(); ++i) {
    size_t diagonal = row[0];
    row[0] = i;
    for (size_t j = 1; j <= b.size(); ++j) {
      const size_t above = row[j];
      row[j] = std::min({above + 1, row[j - 1] + 1, diagonal + (a[i - 1] != b[j - 1])});
      diagonal = above;
    }
  }
  return row[b.size()];
}

// Collects candidates and keeps the nearest: at most a third of the name's characters (and at
// least two) edited; farther is another name, not a typo of this one.
class NearestName {
 public:
  explicit NearestName(std::string_view name)
      : name_(name), best_edits_(std::max<size_t>(2, name.size() / 3) + 1) {}
  void consider(std::string_view candidate) {
    if (const size_t n = edit_distance(name_, candidate); n < best_edits_) {
      best_ = std::string(candidate);
      best_edits_ = n;
    }
  }
  const std::optional<std::string>& best() const { return best_; }
  // "; did you mean NAME?", or nothing when no candidate is near.
  std::string suggestion() const { return best_ ? "; did you mean " + *best_ + "?" : ""; }

 private:
  std::string_view name_;
  size_t best_edits_;
  std::optional<std::string> best_;
};

}  // namespace modtap
