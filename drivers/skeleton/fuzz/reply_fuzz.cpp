// Every datagram a peer could send, through the reply decoder: it accepts
// exactly 8 bytes with the reserved status bits clear, and a decoded reply
// encodes its fields back to the same bytes.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <span>

#include "drivers/skeleton/skeleton_frame.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace hapticd::drivers::skeleton;
  const auto reply = decode_reply(std::span<const std::uint8_t>(data, size));
  if (!reply) return 0;
  if (size != frame_size || (data[2] & 0xFC) != 0) std::abort();
  const std::int32_t back = static_cast<std::int32_t>(
      static_cast<std::uint32_t>(data[4]) | static_cast<std::uint32_t>(data[5]) << 8 |
      static_cast<std::uint32_t>(data[6]) << 16 | static_cast<std::uint32_t>(data[7]) << 24);
  if (reply->position != back || reply->fault_code != data[3]) std::abort();
  return 0;
}
