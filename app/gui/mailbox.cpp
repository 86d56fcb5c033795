#include "app/gui/mailbox.hpp"

#include <QMetaObject>

namespace collide::gui {

void Mailbox::post(std::function<void()> work) {
  std::lock_guard lock(mutex_);
  queue_.push_back(std::move(work));
  // By name and without arguments: the event is Qt's own, nothing of ours in
  // it. Posted under the lock, so the event Qt allocates here happens before
  // deliver() takes the lock on the receiving thread, and before Qt frees it
  // there, in TSan's eyes too. (Posting only queues: deliver() never runs
  // inside post().)
  QMetaObject::invokeMethod(this, "deliver", Qt::QueuedConnection);
}

void Mailbox::deliver() {
  // One item at a time, taken under the lock and run outside it: work that
  // posts more (or opens a nested event loop that delivers) keeps the order.
  for (;;) {
    std::function<void()> work;
    {
      std::lock_guard lock(mutex_);
      if (queue_.empty()) return;
      work = std::move(queue_.front());
      queue_.pop_front();
    }
    work();
  }
}

}  // namespace collide::gui
