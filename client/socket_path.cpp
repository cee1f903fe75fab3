#include "client/socket_path.hpp"

#include <unistd.h>
#include <cstdlib>

namespace hapticd::client {

namespace {
std::string env_dir(const char* name) {
  const char* value = std::getenv(name);  // NOLINT(concurrency-mt-unsafe): nothing here calls setenv
  if (value == nullptr) return {};
  std::string dir(value);
  // systemd joins several RuntimeDirectory= entries with ':'; the first is ours.
  if (auto colon = dir.find(':'); colon != std::string::npos) dir.erase(colon);
  while (dir.size() > 1 && dir.back() == '/') dir.pop_back();
  return dir;
}
}  // namespace

std::string resolve_socket_path(std::string_view configured) {
  if (!configured.empty()) return std::string(configured);
  for (const char* var : {"RUNTIME_DIRECTORY", "XDG_RUNTIME_DIR"}) {
    if (std::string dir = env_dir(var); !dir.empty()) return dir + "/hapticd.sock";
  }
  return "/tmp/hapticd-" + std::to_string(::geteuid()) + ".sock";
}

}  // namespace hapticd::client
