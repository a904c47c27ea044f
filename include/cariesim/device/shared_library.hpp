#pragma once
/// A vendor's C library loaded at run time (dlopen), so that one cariesim binary builds without any
/// haptic SDK and finds the SDK on the station it runs on (docs/devices.md "How a backend finds its
/// SDK"). The library is searched for under an ordered list of names (the dynamic loader's search:
/// LD_LIBRARY_PATH, the ld.so cache, /usr/lib...), unless an environment variable names a path, which
/// is then the only candidate. Every needed symbol is resolved once, at open; a missing one is named
/// in the error.
///
///   SharedLibrary hd = SharedLibrary::open("OpenHaptics HD", {"libHD.so", "libHD.so.3.4"},
///                                          "CARIESIM_HD_LIBRARY");
///   auto* init = hd.symbol<HHD (*)(const char*)>("hdInitDevice");

#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace cariesim {

/// Where a library was looked for and what happened (for `cariesim device list` and error messages).
struct LibraryProbe {
  std::string what;                 ///< e.g. "OpenHaptics HD"
  std::optional<std::string> path;  ///< the file loaded (as the loader resolved it), if any
  /// Each name tried, in order, with the loader's message when it failed.
  std::vector<std::pair<std::string, std::string>> tried;
  std::string env_var;  ///< the environment variable that overrides the search (set or not)
  /// "OpenHaptics HD: not found (tried libHD.so: <why>; ...)", naming the environment variable.
  [[nodiscard]] std::string describe() const;
};

/// A loaded library; unloads it when destroyed (after the device using its functions closed).
class SharedLibrary {
 public:
  /// Loads the first of `names` the dynamic loader finds (or only the path in the environment
  /// variable `env_var`, when it is set and not empty). Throws cariesim::Error naming `what`, every
  /// name tried with the loader's reason, the environment variable, and `install_hint` (what to
  /// install) when none loads.
  static SharedLibrary open(const std::string& what, const std::vector<std::string>& names,
                            const std::string& env_var, const std::string& install_hint = "");
  /// Looks for the library the same way without throwing: the probe says what was found.
  static LibraryProbe probe(const std::string& what, const std::vector<std::string>& names,
                            const std::string& env_var);

  SharedLibrary(SharedLibrary&& other) noexcept;
  SharedLibrary& operator=(SharedLibrary&& other) noexcept;
  SharedLibrary(const SharedLibrary&) = delete;
  SharedLibrary& operator=(const SharedLibrary&) = delete;
  ~SharedLibrary();

  /// The address of a function or variable; throws cariesim::Error "<what> (<path>): missing symbol
  /// <name>: <loader's reason>; the SDK is too old or not the vendor's" when it is not exported.
  [[nodiscard]] void* address(const char* name) const;
  /// address(name) as a function pointer type F.
  template <class F>
  [[nodiscard]] F symbol(const char* name) const {
    return reinterpret_cast<F>(address(name));
  }
  /// The address, or null when the symbol is not exported (optional functions).
  [[nodiscard]] void* find(const char* name) const;
  /// The file loaded.
  [[nodiscard]] const std::string& path() const { return path_; }
  [[nodiscard]] const std::string& what() const { return what_; }

 private:
  SharedLibrary(void* handle, std::string what, std::string path)
      : handle_(handle), what_(std::move(what)), path_(std::move(path)) {}
  void* handle_ = nullptr;
  std::string what_;
  std::string path_;
};

}  // namespace cariesim
