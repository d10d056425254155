#include "runtime/principal_usage.hpp"

#include <numeric>

namespace rv::daemon {

int64_t CellAllowance::total(const std::deque<Charge>& q) {
  return std::accumulate(q.begin(), q.end(), int64_t{0}, [](int64_t s, const Charge& c) { return s + c.cells; });
}

void CellAllowance::expire(std::deque<Charge>& charges, Clock::time_point now) const {
  while (!charges.empty() && charges.front().at + kWindow <= now) charges.pop_front();
}

void CellAllowance::restore(const std::string& principal, Clock::time_point at, int64_t cells) {
  std::lock_guard lock(mutex_);
  auto& q = charges_[principal];
  // Kept in time order: charges_since() need not return them sorted.
  auto it = q.end();
  while (it != q.begin() && std::prev(it)->at > at) --it;
  q.insert(it, Charge{at, cells});
}

std::optional<CellAllowance::Clock::time_point> CellAllowance::fits_at(const std::deque<Charge>& q, int64_t cells,
                                                                       Clock::time_point now) const {
  if (limit_ <= 0) return now;
  if (cells > limit_) return std::nullopt;
  const int64_t used = total(q);
  // The oldest charges age out first: they fit when enough of them have.
  int64_t left = used;
  Clock::time_point when = now;
  for (auto it = q.begin(); left + cells > limit_ && it != q.end(); ++it) {
    left -= it->cells;
    when = it->at + kWindow;
  }
  return when;
}

void CellAllowance::charge(const std::string& principal, int64_t cells, Clock::time_point now) {
  std::lock_guard lock(mutex_);
  auto& q = charges_[principal];
  expire(q, now);
  const auto fits = fits_at(q, cells, now);
  if (!fits)
    throw QuotaExceeded("the grid's " + std::to_string(cells) + " cells exceed the allowance of " +
                            std::to_string(limit_) + " cells per hour of each principal on this server",
                        kWindow.count());
  if (*fits > now) {
    const int64_t used = total(q);
    const int64_t wait = std::chrono::ceil<std::chrono::seconds>(*fits - now).count();
    throw QuotaExceeded("this principal's jobs of the last hour used " + std::to_string(used) + " of its " +
                            std::to_string(limit_) + " cells per hour; this grid needs " + std::to_string(cells) +
                            " more; retry in " + std::to_string(wait) + " s",
                        wait);
  }
  q.push_back(Charge{now, cells});
}

int64_t CellAllowance::retry_after(const std::string& principal, int64_t cells, Clock::time_point now) const {
  std::lock_guard lock(mutex_);
  auto& q = charges_[principal];
  expire(q, now);
  const auto fits = fits_at(q, cells, now);
  if (!fits) return kWindow.count();
  return std::max<int64_t>(1, std::chrono::ceil<std::chrono::seconds>(*fits - now).count());
}

void CellAllowance::refund(const std::string& principal, int64_t cells) {
  std::lock_guard lock(mutex_);
  auto& q = charges_[principal];
  for (auto it = q.rbegin(); it != q.rend(); ++it)
    if (it->cells == cells) {
      q.erase(std::next(it).base());
      return;
    }
}

int64_t CellAllowance::used(const std::string& principal, Clock::time_point now) const {
  std::lock_guard lock(mutex_);
  auto& q = charges_[principal];
  expire(q, now);
  return total(q);
}

}  // namespace rv::daemon
