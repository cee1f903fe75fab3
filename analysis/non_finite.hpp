#pragma once
/// \file
/// The two non-finite values the analyses answer with: NaN for "cannot
/// assess" (a verdict never comes from numbers that are not finite), +inf for
/// an unbounded limit or growth.

#include <limits>

// In a namespace of their own: each source takes what it uses with a
// using-declaration, and names such as MeasurementFault::nan stay unshadowed.
namespace hapticd::analysis::non_finite {

inline constexpr double nan = std::numeric_limits<double>::quiet_NaN();
inline constexpr double inf = std::numeric_limits<double>::infinity();

}  // namespace hapticd::analysis::non_finite
