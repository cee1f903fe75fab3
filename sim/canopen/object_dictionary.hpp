#pragma once
/// \file
/// The simulated drive's object dictionary: each entry with its data type,
/// access, PDO mappability, value and power-on default, as the drive
/// declares them (simulated_drive.cpp, from CiA 301 7.5 and CiA 402-2 6),
/// not looked up in the driver's catalog (its 402/objects.hpp);
/// and the SDO server's generic checks (existence, access, size) with the
/// CiA 301 abort code of each failure.

#include <cstdint>
#include <map>

#include "sim/canopen/wire.hpp"

namespace hapticd::drivers::canopen::sim {

/// CiA 301 7.4.7.1 basic data types (the ones an expedited SDO carries).
enum class DataType : std::uint8_t { unsigned8, unsigned16, unsigned32, integer8, integer16, integer32 };
constexpr std::uint8_t bytes_of(DataType t) noexcept {
  switch (t) {
    case DataType::unsigned8:
    case DataType::integer8:
      return 1;
    case DataType::unsigned16:
    case DataType::integer16:
      return 2;
    case DataType::unsigned32:
    case DataType::integer32:
      return 4;
  }
  return 4;
}

/// CiA 301 7.4.5 access attribute.
enum class Access : std::uint8_t { ro, wo, rw, constant };
/// Which PDO may map the entry (CiA 301 7.4.5 "PDO mapping").
enum class PdoMapping : std::uint8_t { none, rpdo, tpdo };

struct Entry {
  DataType type = DataType::unsigned32;
  Access access = Access::rw;
  PdoMapping mapping = PdoMapping::none;
  std::uint32_t value = 0;  ///< raw little-endian word, low bytes_of(type) bytes significant
  std::uint32_t default_value = 0;
};

class ObjectDictionary {
 public:
  void add(Address address, DataType type, Access access, PdoMapping mapping, std::uint32_t default_value);

  const Entry* find(Address address) const noexcept;
  bool has_index(std::uint16_t index) const noexcept;

  /// 0 if an SDO upload may read the entry, else the abort code
  /// (0x06020000 no object, 0x06090011 no sub-index, 0x06010001 write-only).
  std::uint32_t check_read(Address address) const noexcept;
  /// 0 if an SDO download of `size` bytes (0 = not indicated) may write it,
  /// else 0x06020000, 0x06090011, 0x06010002 read-only, 0x06070012 too long,
  /// 0x06070013 too short.
  std::uint32_t check_write(Address address, std::uint8_t size) const noexcept;

  std::uint32_t get(Address address) const noexcept;        ///< 0 if absent
  void set(Address address, std::uint32_t value) noexcept;  ///< no-op if absent; cut to the type's size
  /// Every entry with first <= index <= last back to its default (the NMT resets).
  void reset(std::uint16_t first, std::uint16_t last) noexcept;

 private:
  std::map<Address, Entry> entries_;
};

}  // namespace hapticd::drivers::canopen::sim
