// Units and physical constants, one definition each. Names carry the unit; every value
// is the exact decimal of its definition rounded once to double.
#pragma once

namespace insid {

inline constexpr double kPi = 3.14159265358979323846;
inline constexpr double kDegToRad = kPi / 180.0;  ///< rad per degree
inline constexpr double kRadToDeg = 180.0 / kPi;  ///< degrees per rad

/// Standard gravity g_n (m/s^2; CGPM 1901, ISO 80000-3): the unit "g" of accelerometer data
/// sheets and logs, not a local gravity.
inline constexpr double kStandardGravity_mps2 = 9.80665;
inline constexpr double kMilliG_mps2 = 9.80665e-3;  ///< 1 mg (m/s^2)
inline constexpr double kMicroG_mps2 = 9.80665e-6;  ///< 1 micro-g (m/s^2)

}  // namespace insid
