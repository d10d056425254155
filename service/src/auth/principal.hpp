// Who asks: the principal a request was authenticated as, and the one rule of who sees what.
// Plain values; thread-safe to copy and read.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

#include "rv/server_config.hpp"

namespace rv::auth {

// The owner of every job on a server without authentication, and of jobs stored before
// principals existed. No configured principal and no identity provider's subject may take it.
inline constexpr std::string_view kAnonymous = "anonymous";

struct Principal {
  std::string name{kAnonymous};
  // Without authentication whoever asks is the anonymous admin: the server is open, as it was.
  Role role = Role::admin;
  // How the request proved it: "none" (no authentication on this server), "token" (a configured
  // token), "jwt" (an identity provider's token).
  std::string how = "none";
  int64_t expires = 0;  // "jwt": the token's "exp" (seconds since 1970); else 0
};

// True when `who` may see (and dismiss, and edit from) a job owned by `owner`: its own, or any
// for an admin. Everything else answers exactly as a job that does not exist.
inline bool may_see(const Principal& who, std::string_view owner) {
  return who.role == Role::admin || who.name == owner;
}

inline std::string_view to_string(Role role) { return role == Role::admin ? "admin" : "user"; }

}  // namespace rv::auth
