#include "output/followed_registers.hpp"

namespace modtap::output {

bool follows(const std::vector<FollowedRegister>& follow, const RegisterValue& reg) {
  if (follow.empty()) return true;
  for (const FollowedRegister& f : follow)
    if (f.name == reg.name || (f.number && f.number->address == reg.address &&
                               f.number->table.value_or(reg.table) == reg.table))
      return true;
  return false;
}

}  // namespace modtap::output
