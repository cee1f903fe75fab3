// Test-only launcher: runs a program under the unit's system call filter,
// address families and private network, as systemd applies them, on a
// machine where systemd is not PID 1 (issue 17). The policy comes from
// tests/systemd_sandbox_policy.sh, which evaluates the unit's own lines with
// systemd's own group lists.
//
// usage: sandbox_exec POLICY -- PROGRAM [ARGS...]
//   POLICY.syscalls  allowed system calls, one a line; any other: EPERM
//                    (the unit's SystemCallErrorNumber=EPERM)
//   POLICY.families  AF_UNIX,AF_CAN,...: socket() of any other family: EAFNOSUPPORT
//   POLICY.network   "private": a new network namespace (PrivateNetwork=yes)
// Only the native architecture's calls are allowed (SystemCallArchitectures=native).
// Not applied: DeviceAllow=, ProtectProc=, ProtectSystem= and the other
// mount-namespace options (they need systemd's cgroup and mount setup).

#include <linux/sched.h>
#include <sched.h>
#include <seccomp.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

namespace {

int family_number(const std::string& name) {
  static const std::map<std::string, int> known{{"AF_UNIX", AF_UNIX},   {"AF_INET", AF_INET},
                                                {"AF_INET6", AF_INET6}, {"AF_NETLINK", AF_NETLINK},
                                                {"AF_CAN", AF_CAN},     {"AF_PACKET", AF_PACKET}};
  const auto it = known.find(name);
  return it == known.end() ? -1 : it->second;
}

std::string read_file(const std::string& path) {
  std::ifstream in(path);
  if (!in) return {};
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

int fail(const std::string& what) {
  std::fprintf(stderr, "sandbox_exec: %s\n", what.c_str());
  return 126;
}

/// The first argument compared with `value` (SCMP_A0 is a C compound literal).
scmp_arg_cmp first_argument(scmp_compare op, int value) {
  scmp_arg_cmp cmp{};
  cmp.arg = 0;
  cmp.op = op;
  cmp.datum_a = static_cast<scmp_datum_t>(value);
  cmp.datum_b = 0;
  return cmp;
}

/// socket(): only the listed families; others EAFNOSUPPORT, as systemd answers.
bool restrict_families(scmp_filter_ctx ctx, const std::string& list) {
  std::vector<int> families;
  std::stringstream in(list);
  for (std::string name; std::getline(in, name, ',');) {
    while (!name.empty() && (name.back() == '\n' || name.back() == ' ')) name.pop_back();
    if (name.empty()) continue;
    const int f = family_number(name);
    if (f < 0) return false;
    families.push_back(f);
  }
  if (families.empty()) return seccomp_rule_add(ctx, SCMP_ACT_ALLOW, SCMP_SYS(socket), 0) == 0;
  for (const int f : families) {
    if (seccomp_rule_add(ctx, SCMP_ACT_ALLOW, SCMP_SYS(socket), 1, first_argument(SCMP_CMP_EQ, f)) != 0)
      return false;
  }
  // Every other family: below and above each allowed one.
  int low = 0;
  std::vector<int> sorted = families;
  std::sort(sorted.begin(), sorted.end());
  for (const int f : sorted) {
    for (int g = low; g < f; ++g)
      seccomp_rule_add(ctx, SCMP_ACT_ERRNO(EAFNOSUPPORT), SCMP_SYS(socket), 1,
                       first_argument(SCMP_CMP_EQ, g));
    low = f + 1;
  }
  return seccomp_rule_add(ctx, SCMP_ACT_ERRNO(EAFNOSUPPORT), SCMP_SYS(socket), 1,
                          first_argument(SCMP_CMP_GE, low)) == 0;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 4 || std::strcmp(argv[2], "--") != 0)
    return fail("usage: sandbox_exec POLICY -- PROGRAM [ARGS...]");
  const std::string policy = argv[1];
  const std::string syscalls = read_file(policy + ".syscalls");
  if (syscalls.empty()) return fail("no system calls in " + policy + ".syscalls");
  const std::string network = read_file(policy + ".network");
  if (network.rfind("private", 0) == 0 && unshare(CLONE_NEWNET) != 0)
    return fail(std::string("unshare(CLONE_NEWNET): ") + std::strerror(errno));

  scmp_filter_ctx ctx = seccomp_init(SCMP_ACT_ERRNO(EPERM));
  if (ctx == nullptr) return fail("seccomp_init failed");
  std::stringstream names(syscalls);
  int added = 0;
  for (std::string name; std::getline(names, name);) {
    if (name.empty() || name == "socket") continue;
    const int nr = seccomp_syscall_resolve_name(name.c_str());
    if (nr == __NR_SCMP_ERROR || nr < 0) continue;  // another architecture's call
    if (seccomp_rule_add(ctx, SCMP_ACT_ALLOW, nr, 0) == 0) ++added;
  }
  const bool socket_allowed =
      syscalls.find("\nsocket\n") != std::string::npos || syscalls.rfind("socket\n", 0) == 0;
  if (socket_allowed && !restrict_families(ctx, read_file(policy + ".families")))
    return fail("bad address family list in " + policy + ".families");
  if (seccomp_load(ctx) != 0) return fail("seccomp_load failed");
  seccomp_release(ctx);
  std::fprintf(stderr, "sandbox_exec: %d system calls allowed, %s network\n", added,
               network.rfind("private", 0) == 0 ? "private" : "host");
  execv(argv[3], argv + 3);
  return fail(std::string("execv ") + argv[3] + ": " + std::strerror(errno));
}
