#include "drivers/canopen/301/object.hpp"

#include <cstdio>

namespace hapticd::drivers::canopen::cia301 {

std::string to_string(ObjectAddress address) {
  char text[16];
  std::snprintf(text, sizeof text, "0x%04X:%02X", static_cast<unsigned>(address.index),
                static_cast<unsigned>(address.sub));
  return text;
}

std::string_view short_name(DataType type) noexcept {
  switch (type) {
    case DataType::boolean:
      return "bool";
    case DataType::integer8:
      return "i8";
    case DataType::integer16:
      return "i16";
    case DataType::integer32:
      return "i32";
    case DataType::unsigned8:
      return "u8";
    case DataType::unsigned16:
      return "u16";
    case DataType::unsigned32:
      return "u32";
  }
  return "?";
}

std::optional<DataType> parse_data_type(std::string_view name) noexcept {
  for (const DataType t : {DataType::boolean, DataType::integer8, DataType::integer16, DataType::integer32,
                           DataType::unsigned8, DataType::unsigned16, DataType::unsigned32}) {
    if (name == short_name(t)) return t;
  }
  return std::nullopt;
}

std::string_view accepted_data_type_names() noexcept { return "u8, u16, u32, i8, i16, i32, bool"; }

std::optional<std::uint32_t> to_raw(DataType type, std::int64_t value) noexcept {
  const unsigned bits = 8U * size_of(type);
  if (type == DataType::boolean) {
    if (value != 0 && value != 1) return std::nullopt;
    return static_cast<std::uint32_t>(value);
  }
  if (is_signed(type)) {
    const std::int64_t lo = -(std::int64_t{1} << (bits - 1));
    const std::int64_t hi = (std::int64_t{1} << (bits - 1)) - 1;
    if (value < lo || value > hi) return std::nullopt;
    const std::uint64_t mask = (std::uint64_t{1} << bits) - 1;
    return static_cast<std::uint32_t>(static_cast<std::uint64_t>(value) & mask);
  }
  const std::int64_t hi = static_cast<std::int64_t>((std::uint64_t{1} << bits) - 1);
  if (value < 0 || value > hi) return std::nullopt;
  return static_cast<std::uint32_t>(value);
}

std::int64_t from_raw(DataType type, std::uint32_t raw) noexcept {
  const unsigned bits = 8U * size_of(type);
  const std::uint64_t mask = (std::uint64_t{1} << bits) - 1;
  const std::uint64_t v = raw & mask;
  if (is_signed(type) && (v >> (bits - 1)) != 0)
    return static_cast<std::int64_t>(v) - static_cast<std::int64_t>(mask + 1);
  return static_cast<std::int64_t>(v);
}

}  // namespace hapticd::drivers::canopen::cia301
