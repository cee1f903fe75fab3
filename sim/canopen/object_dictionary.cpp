#include "sim/canopen/object_dictionary.hpp"

#include "sim/canopen/sdo_server.hpp"

namespace hapticd::drivers::canopen::sim {

void ObjectDictionary::add(Address address, DataType type, Access access, PdoMapping mapping,
                           std::uint32_t default_value) {
  entries_[address] = Entry{type, access, mapping, default_value, default_value};
}

const Entry* ObjectDictionary::find(Address address) const noexcept {
  const auto it = entries_.find(address);
  return it == entries_.end() ? nullptr : &it->second;
}

bool ObjectDictionary::has_index(std::uint16_t index) const noexcept {
  const auto it = entries_.lower_bound(Address{index, 0});
  return it != entries_.end() && it->first.index == index;
}

std::uint32_t ObjectDictionary::check_read(Address address) const noexcept {
  const Entry* e = find(address);
  if (e == nullptr) return has_index(address.index) ? abort_code::no_sub_index : abort_code::no_object;
  if (e->access == Access::wo) return abort_code::write_only;
  return 0;
}

std::uint32_t ObjectDictionary::check_write(Address address, std::uint8_t size) const noexcept {
  const Entry* e = find(address);
  if (e == nullptr) return has_index(address.index) ? abort_code::no_sub_index : abort_code::no_object;
  if (e->access == Access::ro || e->access == Access::constant) return abort_code::read_only;
  const std::uint8_t expected = bytes_of(e->type);
  if (size != 0 && size > expected) return abort_code::length_too_high;
  if (size != 0 && size < expected) return abort_code::length_too_low;
  return 0;
}

std::uint32_t ObjectDictionary::get(Address address) const noexcept {
  const Entry* e = find(address);
  return e == nullptr ? 0 : e->value;
}

void ObjectDictionary::set(Address address, std::uint32_t value) noexcept {
  const auto it = entries_.find(address);
  if (it == entries_.end()) return;
  const std::uint8_t bytes = bytes_of(it->second.type);
  it->second.value = bytes >= 4 ? value : value & ((1U << (8U * bytes)) - 1U);
}

void ObjectDictionary::reset(std::uint16_t first, std::uint16_t last) noexcept {
  for (auto& [address, entry] : entries_)
    if (address.index >= first && address.index <= last) entry.value = entry.default_value;
}

}  // namespace hapticd::drivers::canopen::sim
