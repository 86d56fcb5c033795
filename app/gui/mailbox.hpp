#pragma once
// Work handed to the thread a QObject lives in through a std::mutex, not
// through the payload of a Qt event.
//
// Why: Qt is not built with ThreadSanitizer, so the lock under which a queued
// signal or invokeMethod hands its arguments to another thread is invisible to
// it, and every payload looks raced. Here the payload (a std::function and
// what it captured) crosses under a std::mutex TSan sees; the Qt event that
// wakes the receiving thread carries nothing (invoked by name, so Qt alone
// allocates and frees it). RigWorker takes its requests and sends its signals
// this way, which lets `./collide.sh tsan` check the rig's control thread.
#include <QObject>
#include <deque>
#include <functional>
#include <mutex>

namespace collide::gui {

class Mailbox : public QObject {
  Q_OBJECT
 public:
  explicit Mailbox(QObject* parent = nullptr) : QObject(parent) {}

  /// Any thread: `work` runs later on this object's thread, after everything
  /// posted before it (first in, first out, also across nested event loops).
  /// Work still queued when the mailbox is destroyed is dropped, not run.
  void post(std::function<void()> work);

 private:
  /// This object's thread: runs the queued work, oldest first.
  Q_INVOKABLE void deliver();

  std::mutex mutex_;
  std::deque<std::function<void()>> queue_;
};

}  // namespace collide::gui
