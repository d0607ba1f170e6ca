#include "output/network/shared_library.hpp"

#include <dlfcn.h>

#include <stdexcept>

#include <fmt/format.h>

namespace modtap::output {

SharedLibrary::SharedLibrary(const char* soname, const char* who, const char* package)
    : soname_(soname), handle_(dlopen(soname, RTLD_NOW | RTLD_LOCAL)) {
  if (!handle_)
    throw std::runtime_error(
        fmt::format("{} needs {} (Debian package {}): {}", who, soname, package, dlerror()));
}

void* SharedLibrary::find(const char* function) const {
  void* found = dlsym(handle_, function);
  if (!found)
    throw std::runtime_error(fmt::format("{} has no {}: {}", soname_, function, dlerror()));
  return found;
}

}  // namespace modtap::output
