#pragma once
/// \file
/// The simulated drive's object dictionary: entries described by the
/// standard catalog (301/object_dictionary.hpp, 402/objects.hpp), each with
/// its value and its power-on default, and the SDO server's generic checks
/// (existence, access, size) with the CiA 301 abort code of each failure.

#include <cstdint>
#include <map>

#include "drivers/canopen/301/object_dictionary.hpp"

namespace hapticd::drivers::canopen::sim {

struct Entry {
  cia301::ObjectInfo info;
  std::uint32_t value = 0;  ///< raw little-endian word, low size_of(type) bytes significant
  std::uint32_t default_value = 0;
};

class ObjectDictionary {
 public:
  /// Adds an entry described by the standard catalog; throws std::logic_error if unknown.
  void add(cia301::ObjectAddress address, std::uint32_t default_value);
  void add_described(const cia301::ObjectInfo& info, std::uint32_t default_value);

  const Entry* find(cia301::ObjectAddress address) const noexcept;
  bool has_index(std::uint16_t index) const noexcept;

  /// 0 if an SDO upload may read the entry, else the abort code
  /// (0x06020000 no object, 0x06090011 no sub-index, 0x06010001 write-only).
  std::uint32_t check_read(cia301::ObjectAddress address) const noexcept;
  /// 0 if an SDO download of `size` bytes (0 = not indicated) may write it,
  /// else 0x06020000, 0x06090011, 0x06010002 read-only, 0x06070012 too long,
  /// 0x06070013 too short.
  std::uint32_t check_write(cia301::ObjectAddress address, std::uint8_t size) const noexcept;

  std::uint32_t get(cia301::ObjectAddress address) const noexcept;  ///< 0 if absent
  std::int64_t get_signed(cia301::ObjectAddress address) const noexcept;
  void set(cia301::ObjectAddress address, std::uint32_t value) noexcept;  ///< no-op if absent
  /// Every entry with lo <= index <= hi back to its default (NMT resets).
  void reset(std::uint16_t lo, std::uint16_t hi) noexcept;

 private:
  std::map<cia301::ObjectAddress, Entry> entries_;
};

}  // namespace hapticd::drivers::canopen::sim
