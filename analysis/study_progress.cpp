#include "analysis/study_progress.hpp"

#include <ctime>

namespace hapticd::analysis {

double process_cpu_seconds() noexcept { return static_cast<double>(std::clock()) / CLOCKS_PER_SEC; }

}  // namespace hapticd::analysis
