// A library loaded when an option asks for it, not at every start. libmosquitto (--mqtt) and
// libmicrohttpd (--metrics) bring OpenSSL and GnuTLS: loading and relocating their 25
// libraries was more than half of the start of every run, for the few runs that use them
// (docs/performance.md). Their headers still declare the functions; MODTAP_SYMBOL gives each
// loaded function the type its header declares, so a call is checked as a linked one is.
#pragma once

#include <string>

namespace modtap::output {

class SharedLibrary {
 public:
  // Loads `soname` or throws std::runtime_error naming `who` (the option that needs it) and
  // `package` (where a Debian user gets it). A loaded library stays for the process's life:
  // its threads (libmosquitto's network loop, libmicrohttpd's server) may outlive any owner.
  SharedLibrary(const char* soname, const char* who, const char* package);

  // The named function, or std::runtime_error when the library lacks it.
  void* find(const char* function) const;

 private:
  std::string soname_;
  void* handle_;
};

}  // namespace modtap::output

// `function` from `library`, with the type its header declares.
#define MODTAP_SYMBOL(library, function) \
  reinterpret_cast<decltype(&::function)>((library).find(#function))
