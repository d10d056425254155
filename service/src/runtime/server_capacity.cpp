#include "runtime/server_capacity.hpp"

#include <algorithm>
#include <chrono>

#include "runtime/server_util.hpp"
#include "rv/field/error.hpp"

namespace rv::daemon {

MemoryAccount::MemoryAccount(int64_t total_bytes) : total_(std::max<int64_t>(total_bytes, 0)) {}

MemoryAccount::Reservation& MemoryAccount::Reservation::operator=(Reservation&& o) noexcept {
  if (this != &o) {
    release();
    account_ = o.account_;
    held_ = o.held_;
    standing_ = o.standing_;
    o.account_ = nullptr;
    o.held_ = 0;
  }
  return *this;
}

void MemoryAccount::Reservation::need(int64_t bytes, bool wait, const std::atomic<bool>* cancel,
                                      const std::string& what) {
  if (account_ == nullptr || bytes <= held_) return;
  account_->grow(*this, bytes, wait, cancel, what);
}

void MemoryAccount::Reservation::release() {
  if (account_ == nullptr || held_ == 0) return;
  account_->give_back(held_, !standing_);
  held_ = 0;
}

void MemoryAccount::Reservation::settle(int64_t bytes) {
  if (account_ != nullptr) account_->settle(*this, bytes);
}

void MemoryAccount::settle(Reservation& r, int64_t bytes) {
  {
    std::lock_guard lock(mutex_);
    const int64_t keep = std::clamp<int64_t>(bytes, 0, r.held_);
    reserved_ -= r.held_ - keep;
    if (r.held_ > 0 && !r.standing_) --holders_;
    r.held_ = keep;
    r.standing_ = true;
  }
  freed_.notify_all();
}

int64_t MemoryAccount::reserved() const {
  std::lock_guard lock(mutex_);
  return reserved_;
}

int MemoryAccount::waiting() const {
  std::lock_guard lock(mutex_);
  return static_cast<int>(waiting_.size());
}

void MemoryAccount::grow(Reservation& r, int64_t bytes, bool wait, const std::atomic<bool>* cancel,
                         const std::string& what) {
  if (bytes > total_)
    throw Error(ErrorKind::too_large, what + " needs about " + mib_text(bytes) +
                                          ", more than this server's memory budget of " + mib_text(total_));
  std::unique_lock lock(mutex_);
  // A grant a quarter above the request: an estimate that grows feature by feature asks the
  // account a few dozen times, not once per feature.
  auto try_grant = [&] {
    const int64_t free = total_ - reserved_;
    if (bytes - r.held_ > free) return false;
    const int64_t target = std::clamp(bytes + bytes / 4, bytes, r.held_ + free);
    if (r.held_ == 0 && !r.standing_) ++holders_;
    reserved_ += target - r.held_;
    r.held_ = target;
    return true;
  };
  if (try_grant()) return;
  const std::string refused = what + " needs about " + mib_text(bytes) + " of memory and " +
                              mib_text(total_ - reserved_) + " of this server's " + mib_text(total_) + " are free";
  if (!wait) throw Error(ErrorKind::busy, refused + "; retry later");
  const uint64_t ticket = ++next_ticket_;
  waiting_[ticket] = Waiter{r.held_ > 0, bytes - r.held_};
  auto leave = [&] {
    waiting_.erase(ticket);
    if (give_way_ == ticket) give_way_ = 0;
  };
  for (;;) {
    // When every holder waits and no waiter fits in what is free, nothing will be given back: the
    // youngest holder gives way. (A waiter that fits is granted as soon as it wakes.)
    int64_t waiting_holders = 0;
    uint64_t youngest_holder = 0;
    bool one_fits = false;
    for (const auto& [t, w] : waiting_) {
      one_fits = one_fits || w.more <= total_ - reserved_;
      if (w.holds) {
        ++waiting_holders;
        youngest_holder = t;
      }
    }
    if (give_way_ == 0 && holders_ > 0 && waiting_holders == holders_ && !one_fits) {
      give_way_ = youngest_holder;
      freed_.notify_all();
    }
    if (give_way_ == ticket) {
      leave();
      freed_.notify_all();
      throw Error(ErrorKind::busy, refused + ", and the work holding the rest waits for memory too; resubmit it");
    }
    if (cancel != nullptr && cancel->load()) {
      leave();
      throw Error(ErrorKind::cancelled, what + " was cancelled while waiting for memory");
    }
    freed_.wait_for(lock, std::chrono::milliseconds(100));
    if (try_grant()) {
      leave();
      return;
    }
  }
}

void MemoryAccount::give_back(int64_t bytes, bool holder_ends) {
  {
    std::lock_guard lock(mutex_);
    reserved_ -= bytes;
    if (holder_ends) --holders_;
  }
  freed_.notify_all();
}

RequestPool::RequestPool(int workers) {
  for (int i = 0; i < std::max(1, workers); ++i) threads_.emplace_back([this] { loop(); });
}

RequestPool::~RequestPool() { stop(); }

void RequestPool::try_run(Task task) {
  {
    std::lock_guard lock(mutex_);
    if (stopping_ || busy_ + static_cast<int>(tasks_.size()) >= static_cast<int>(threads_.size()))
      throw Error(ErrorKind::busy, "every one of this server's " + std::to_string(threads_.size()) +
                                       " threads for such requests is busy; retry later");
    tasks_.push_back(std::move(task));
  }
  work_.notify_one();
}

void RequestPool::loop() {
  for (;;) {
    Task task;
    {
      std::unique_lock lock(mutex_);
      work_.wait(lock, [&] { return stopping_ || !tasks_.empty(); });
      if (tasks_.empty()) return;  // stopping, and nothing left to run
      task = std::move(tasks_.front());
      tasks_.pop_front();
      ++busy_;
    }
    const std::function<void()> hand_over = task();
    {
      std::lock_guard lock(mutex_);
      --busy_;
    }
    if (hand_over) hand_over();
  }
}

void RequestPool::stop() {
  {
    std::lock_guard lock(mutex_);
    if (stopping_ && threads_.empty()) return;
    stopping_ = true;
  }
  work_.notify_all();
  for (std::thread& t : threads_)
    if (t.joinable()) t.join();
  threads_.clear();
}

int RequestPool::busy() const {
  std::lock_guard lock(mutex_);
  return busy_ + static_cast<int>(tasks_.size());
}

}  // namespace rv::daemon
