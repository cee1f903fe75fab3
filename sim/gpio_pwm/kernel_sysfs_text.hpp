#pragma once
/// \file
/// How the kernel's sysfs store() methods read what user space writes, for
/// the simulated PWM chip, written from lib/kstrtox.c and
/// fs/sysfs/file.c, not with the driver's parser (drivers/gpio_pwm/
/// sysfs_value.hpp): a misreading of what the kernel takes then shows as a
/// failure instead of passing both ends.
///
/// kstrtoull(s, base): an optional '+', then digits of `base`; base 0 picks
/// it from the prefix ("0x" + a hex digit: 16, a leading "0": 8, else 10);
/// base 16 skips a "0x"; then at most one '\n' and the end of the text.
/// No digits, or anything else: EINVAL; above the type: ERANGE.
/// kstrtoint: an optional '-' before the same, within int. sysfs_streq: equal
/// but for one trailing '\n' on either side. No allocation (the stores run
/// on the driver's RT thread).

#include <cstddef>
#include <cstdint>
#include <string_view>

namespace hapticd::drivers::gpio_pwm::sim {

/// 0, EINVAL or ERANGE, as kstrtoull() (kstrtou64()).
int kernel_kstrtoull(std::string_view text, unsigned base, std::uint64_t& value) noexcept;
/// 0, EINVAL or ERANGE, as kstrtouint().
int kernel_kstrtouint(std::string_view text, unsigned base, unsigned& value) noexcept;
/// 0, EINVAL or ERANGE, as kstrtoint().
int kernel_kstrtoint(std::string_view text, unsigned base, int& value) noexcept;
/// sysfs_streq(): equal, ignoring one trailing newline on either.
bool kernel_sysfs_streq(std::string_view written, std::string_view word) noexcept;

/// "%llu\n" into `out`; returns the length, 0 if `size` < 21.
std::size_t kernel_print_llu(std::uint64_t value, char* out, std::size_t size) noexcept;

}  // namespace hapticd::drivers::gpio_pwm::sim
