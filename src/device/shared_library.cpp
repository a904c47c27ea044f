#include "cariesim/device/shared_library.hpp"

#include <dlfcn.h>

#include <cstdlib>
#include <utility>

#include "cariesim/common/error.hpp"

namespace cariesim {

namespace {

// The candidates: the environment variable's path alone when it is set, else the names in order.
std::vector<std::string> candidates(const std::vector<std::string>& names, const std::string& env_var) {
  const char* override_path = env_var.empty() ? nullptr : std::getenv(env_var.c_str());
  if (override_path != nullptr && *override_path != '\0') return {override_path};
  return names;
}

// Loads the first candidate that the loader accepts; records each attempt.
void* load(const std::vector<std::string>& names, const std::string& env_var, LibraryProbe& probe) {
  for (const std::string& name : candidates(names, env_var)) {
    dlerror();
    void* handle = dlopen(name.c_str(), RTLD_NOW | RTLD_LOCAL);
    if (handle != nullptr) {
      probe.path = name;
      // The path the loader resolved (dlinfo would need _GNU_SOURCE's link map; dladdr of a symbol
      // is not portable across SDKs, so the name asked for is what is reported when it had a '/').
      return handle;
    }
    const char* why = dlerror();
    probe.tried.emplace_back(name, why != nullptr ? why : "not loaded");
  }
  return nullptr;
}

}  // namespace

std::string LibraryProbe::describe() const {
  if (path) return what + ": " + *path;
  std::string out = what + ": not found (tried";
  for (std::size_t i = 0; i < tried.size(); ++i)
    out += (i == 0 ? " " : "; ") + tried[i].first + ": " + tried[i].second;
  out += ")";
  if (!env_var.empty()) {
    const char* set = std::getenv(env_var.c_str());
    out += set != nullptr && *set != '\0' ? "; " + env_var + " is set to '" + set + "'"
                                          : "; set " + env_var + " to choose where to look";
  }
  return out;
}

LibraryProbe SharedLibrary::probe(const std::string& what, const std::vector<std::string>& names,
                                  const std::string& env_var) {
  LibraryProbe probe{what, std::nullopt, {}, env_var};
  if (void* handle = load(names, env_var, probe)) dlclose(handle);
  return probe;
}

SharedLibrary SharedLibrary::open(const std::string& what, const std::vector<std::string>& names,
                                  const std::string& env_var, const std::string& install_hint) {
  LibraryProbe probe{what, std::nullopt, {}, env_var};
  void* handle = load(names, env_var, probe);
  if (handle == nullptr)
    throw Error(probe.describe() + (install_hint.empty() ? "" : "; " + install_hint));
  return SharedLibrary(handle, what, *probe.path);
}

SharedLibrary::SharedLibrary(SharedLibrary&& other) noexcept
    : handle_(std::exchange(other.handle_, nullptr)),
      what_(std::move(other.what_)),
      path_(std::move(other.path_)) {}

SharedLibrary& SharedLibrary::operator=(SharedLibrary&& other) noexcept {
  if (this != &other) {
    if (handle_ != nullptr) dlclose(handle_);
    handle_ = std::exchange(other.handle_, nullptr);
    what_ = std::move(other.what_);
    path_ = std::move(other.path_);
  }
  return *this;
}

SharedLibrary::~SharedLibrary() {
  if (handle_ != nullptr) dlclose(handle_);
}

void* SharedLibrary::find(const char* name) const {
  if (handle_ == nullptr) return nullptr;
  dlerror();
  return dlsym(handle_, name);
}

void* SharedLibrary::address(const char* name) const {
  if (handle_ == nullptr) throw Error(what_ + ": library not loaded");
  dlerror();
  void* address = dlsym(handle_, name);
  const char* why = dlerror();
  if (address == nullptr || why != nullptr)
    throw Error(what_ + " (" + path_ + "): missing symbol " + name + ": " +
                (why != nullptr ? why : "null address") +
                "; the SDK is older than cariesim needs, or not the vendor's library");
  return address;
}

}  // namespace cariesim
