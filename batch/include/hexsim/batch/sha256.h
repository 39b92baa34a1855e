// SHA-256 (FIPS 180-4), for content-derived run ids.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <string_view>

namespace hexsim::batch {

std::array<uint8_t, 32> Sha256(std::string_view data);
// Lower-case hex of the digest (64 characters).
std::string Sha256Hex(std::string_view data);

}  // namespace hexsim::batch
