// Each principal's hourly allowance of grid cells (limits.cells_per_principal_per_hour): a
// sliding window of the last hour, charged once per job when its grid's size is known, and
// restored from the job store at start (a restart does not hand out a fresh hour).
// Thread safety: every member may be called from any thread.
#pragma once

#include <chrono>
#include <cstdint>
#include <deque>
#include <map>
#include <mutex>
#include <optional>
#include <string>

#include "rv/field/error.hpp"

namespace rv::daemon {

// An rv::Error(over_quota) that knows when to come back: Retry-After, in whole seconds (>= 1).
class QuotaExceeded : public Error {
 public:
  QuotaExceeded(const std::string& message, int64_t retry_after_s)
      : Error(ErrorKind::over_quota, message), retry_after_s_(retry_after_s < 1 ? 1 : retry_after_s) {}
  int64_t retry_after_s() const { return retry_after_s_; }

 private:
  int64_t retry_after_s_;
};

// Retry-After for a principal at its most jobs: when one ends is unknown; a client polling its
// jobs learns it sooner.
inline constexpr int64_t kJobsRetryAfterS = 15;

class CellAllowance {
 public:
  using Clock = std::chrono::system_clock;
  // `cells_per_hour` 0 = unlimited (charges are still counted, for the record).
  explicit CellAllowance(int64_t cells_per_hour) : limit_(cells_per_hour) {}

  // A charge made before this process started (the store's jobs of the last hour).
  void restore(const std::string& principal, Clock::time_point at, int64_t cells);
  // Charges `cells` to `principal` now. Throws QuotaExceeded (charging nothing) when that would
  // take the last hour's charges over the allowance: Retry-After is when enough of them age out
  // (a grid larger than the whole allowance is refused with the hour).
  void charge(const std::string& principal, int64_t cells, Clock::time_point now = Clock::now());
  // Seconds until `cells` more would fit in `principal`'s hour (1 when they fit now; the whole
  // hour for a grid over the allowance): the Retry-After of a job that failed over it.
  int64_t retry_after(const std::string& principal, int64_t cells, Clock::time_point now = Clock::now()) const;
  // Gives a charge back (a submission refused after it was charged).
  void refund(const std::string& principal, int64_t cells);
  // The cells charged to `principal` within the hour before `now`.
  int64_t used(const std::string& principal, Clock::time_point now = Clock::now()) const;

  static constexpr std::chrono::seconds kWindow{3600};

 private:
  struct Charge {
    Clock::time_point at;
    int64_t cells;
  };
  void expire(std::deque<Charge>& charges, Clock::time_point now) const;
  static int64_t total(const std::deque<Charge>& charges);
  // When `cells` more fit beside `charges` (expired ones removed): `now` if they fit, never for a
  // grid over the allowance (nullopt). Call with mutex_ held.
  std::optional<Clock::time_point> fits_at(const std::deque<Charge>& charges, int64_t cells,
                                           Clock::time_point now) const;

  int64_t limit_;
  mutable std::mutex mutex_;
  mutable std::map<std::string, std::deque<Charge>> charges_;
};

}  // namespace rv::daemon
