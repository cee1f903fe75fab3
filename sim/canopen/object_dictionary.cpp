#include "sim/canopen/object_dictionary.hpp"

#include <stdexcept>

#include "drivers/canopen/301/sdo.hpp"
#include "drivers/canopen/402/objects.hpp"

namespace hapticd::drivers::canopen::sim {

using cia301::ObjectAddress;
namespace abort_code = cia301::abort_code;

void ObjectDictionary::add(ObjectAddress address, std::uint32_t default_value) {
  const auto info = cia402::find_standard_object(address);
  if (!info)
    throw std::logic_error("simulated drive: no standard description for " + cia301::to_string(address));
  add_described(*info, default_value);
}

void ObjectDictionary::add_described(const cia301::ObjectInfo& info, std::uint32_t default_value) {
  entries_[info.address] = Entry{info, default_value, default_value};
}

const Entry* ObjectDictionary::find(ObjectAddress address) const noexcept {
  const auto it = entries_.find(address);
  return it == entries_.end() ? nullptr : &it->second;
}

bool ObjectDictionary::has_index(std::uint16_t index) const noexcept {
  const auto it = entries_.lower_bound(ObjectAddress{index, 0});
  return it != entries_.end() && it->first.index == index;
}

std::uint32_t ObjectDictionary::check_read(ObjectAddress address) const noexcept {
  const Entry* e = find(address);
  if (e == nullptr) return has_index(address.index) ? abort_code::no_sub_index : abort_code::no_object;
  if (!cia301::readable(e->info.access)) return abort_code::write_only;
  return 0;
}

std::uint32_t ObjectDictionary::check_write(ObjectAddress address, std::uint8_t size) const noexcept {
  const Entry* e = find(address);
  if (e == nullptr) return has_index(address.index) ? abort_code::no_sub_index : abort_code::no_object;
  if (!cia301::writable(e->info.access)) return abort_code::read_only;
  const std::uint8_t expected = cia301::size_of(e->info.type);
  if (size != 0 && size > expected) return abort_code::length_too_high;
  if (size != 0 && size < expected) return abort_code::length_too_low;
  return 0;
}

std::uint32_t ObjectDictionary::get(ObjectAddress address) const noexcept {
  const Entry* e = find(address);
  return e == nullptr ? 0 : e->value;
}

std::int64_t ObjectDictionary::get_signed(ObjectAddress address) const noexcept {
  const Entry* e = find(address);
  return e == nullptr ? 0 : cia301::from_raw(e->info.type, e->value);
}

void ObjectDictionary::set(ObjectAddress address, std::uint32_t value) noexcept {
  const auto it = entries_.find(address);
  if (it == entries_.end()) return;
  const std::uint8_t size = cia301::size_of(it->second.info.type);
  it->second.value = size >= 4 ? value : value & ((1U << (8U * size)) - 1U);
}

void ObjectDictionary::reset(std::uint16_t lo, std::uint16_t hi) noexcept {
  for (auto& [address, entry] : entries_)
    if (address.index >= lo && address.index <= hi) entry.value = entry.default_value;
}

}  // namespace hapticd::drivers::canopen::sim
