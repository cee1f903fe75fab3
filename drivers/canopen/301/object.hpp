#pragma once
/// \file
/// Object dictionary basics (CiA 301): an entry is addressed by a 16-bit
/// index and an 8-bit sub-index; its basic data type has a CiA 301 data type
/// index (0x0001 BOOLEAN ... 0x0007 UNSIGNED32) and a size on the wire.
/// Only the types an expedited SDO carries (1..4 bytes) are modelled.

#include <compare>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace hapticd::drivers::canopen::cia301 {

struct ObjectAddress {
  std::uint16_t index = 0;
  std::uint8_t sub = 0;
  // clang-tidy 14 takes the defaulted comparison's implicit `0` for a null
  // pointer constant (a known false positive of modernize-use-nullptr).
  // NOLINTNEXTLINE(modernize-use-nullptr)
  friend constexpr auto operator<=>(const ObjectAddress&, const ObjectAddress&) = default;
};
/// "0x6041:00"
std::string to_string(ObjectAddress address);

/// Basic data types and their CiA 301 data type index (object 0x0001..0x0007).
enum class DataType : std::uint16_t {
  boolean = 0x0001,
  integer8 = 0x0002,
  integer16 = 0x0003,
  integer32 = 0x0004,
  unsigned8 = 0x0005,
  unsigned16 = 0x0006,
  unsigned32 = 0x0007,
};
constexpr std::uint8_t size_of(DataType type) noexcept {
  switch (type) {
    case DataType::boolean:
    case DataType::integer8:
    case DataType::unsigned8:
      return 1;
    case DataType::integer16:
    case DataType::unsigned16:
      return 2;
    case DataType::integer32:
    case DataType::unsigned32:
      return 4;
  }
  return 0;
}
constexpr bool is_signed(DataType type) noexcept {
  return type == DataType::integer8 || type == DataType::integer16 || type == DataType::integer32;
}
/// "u8", "u16", "u32", "i8", "i16", "i32", "bool" (the names the commissioning method accepts).
std::string_view short_name(DataType type) noexcept;
std::optional<DataType> parse_data_type(std::string_view name) noexcept;
std::string_view accepted_data_type_names() noexcept;

/// The raw little-endian word (as an SDO carries it) of `value` in `type`;
/// nullopt if the value does not fit the type's range.
std::optional<std::uint32_t> to_raw(DataType type, std::int64_t value) noexcept;
/// The numeric value of a raw word in `type` (sign-extended for INTEGERn).
std::int64_t from_raw(DataType type, std::uint32_t raw) noexcept;

}  // namespace hapticd::drivers::canopen::cia301
