#include "daemon/system/dma_latency.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <system_error>

namespace hapticd::daemon::system {

CpuDmaLatencyRequest CpuDmaLatencyRequest::open(std::int32_t max_latency_us, std::string* error,
                                                const char* path) {
  CpuDmaLatencyRequest r;
  const int fd = ::open(path, O_RDWR | O_CLOEXEC);
  if (fd < 0) {
    if (error)
      *error = std::string("cannot open ") + path + ": " + std::generic_category().message(errno) +
               " (needs root or write access to it; without it deep idle states raise p99 wake-up latency)";
    return r;
  }
  const ssize_t n = ::write(fd, &max_latency_us, sizeof max_latency_us);
  if (n != static_cast<ssize_t>(sizeof max_latency_us)) {
    if (error)
      *error = std::string("cannot write to ") + path + ": " + std::generic_category().message(errno);
    ::close(fd);
    return r;
  }
  r.fd_ = fd;
  return r;
}

CpuDmaLatencyRequest& CpuDmaLatencyRequest::operator=(CpuDmaLatencyRequest&& o) noexcept {
  if (this != &o) {
    release();
    fd_ = o.fd_;
    o.fd_ = -1;
  }
  return *this;
}

CpuDmaLatencyRequest::~CpuDmaLatencyRequest() { release(); }

void CpuDmaLatencyRequest::release() noexcept {
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
}

}  // namespace hapticd::daemon::system
