#pragma once
/// \file
/// Error codes of a drive in words: the codes CiA 402 / IEC 61800-7-201
/// define for drives (0x2310 continuous over current, 0x3210 DC link
/// over-voltage, 0x7305 incremental sensor 1 fault, 0x8611 following error
/// ...), then the CiA 301 communication codes, then the class of the code.
/// Used for EMCY messages and for 0x603F.

#include <cstdint>
#include <string>
#include <string_view>

#include "drivers/canopen/301/emcy.hpp"

namespace hapticd::drivers::canopen::cia402 {

/// The most specific words for an error code; falls back to the class
/// ("current: code 0x2399 not defined by CiA 402").
std::string describe_error_code(std::uint16_t code);

/// One line for an EMCY: "EMCY 0x2310: continuous over current (motor side);
/// error register 0x03 (generic, current); manufacturer bytes 00 00 00 00 00".
std::string describe_emergency(const cia301::Emergency& emcy);

}  // namespace hapticd::drivers::canopen::cia402
