#include "client/socket_path.hpp"

#include <sys/stat.h>
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

std::string service_socket_path(std::string_view instance) {
  std::string dir = "/run/hapticd";
  if (!instance.empty()) dir += "/" + std::string(instance);
  return dir + "/hapticd.sock";
}

std::string resolve_client_socket_path(std::string_view configured, std::string_view instance) {
  if (!configured.empty()) return std::string(configured);
  if (!instance.empty()) return service_socket_path(instance);
  if (std::string env = env_dir("HAPTICD_SOCKET"); !env.empty()) return env;
  auto is_socket = [](const std::string& path) {
    struct stat st {};
    return ::stat(path.c_str(), &st) == 0 && S_ISSOCK(st.st_mode);
  };
  std::string own = resolve_socket_path();
  if (is_socket(own)) return own;
  if (std::string service = service_socket_path(); is_socket(service)) return service;
  return own;
}

}  // namespace hapticd::client
