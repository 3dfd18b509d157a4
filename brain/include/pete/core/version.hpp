#pragma once

namespace pete::core {

/// The Brain firmware's version, sent in Hello (keep in step with pyproject.toml).
inline constexpr char kSoftwareVersion[] = "0.1.0";

}  // namespace pete::core
