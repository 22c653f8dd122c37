// Waiting for a task of an OpenImageIO thread pool without idling: the waiting thread runs the
// pool's queued tasks meanwhile and blocks only when none is left to take. Internal to tiles/
// (included by .cc files only: it brings OpenImageIO's thread header in).
#pragma once

#include <OpenImageIO/thread.h>

#include <chrono>
#include <future>
#include <thread>

namespace zoomwarp::tiles {

// Returns when `task` has finished (its exception, if any, is left in it for get()).
inline void wait_helping(OIIO::thread_pool& pool, const std::future<void>& task) {
  while (task.wait_for(std::chrono::seconds(0)) != std::future_status::ready)
    if (!pool.run_one_task(std::this_thread::get_id())) task.wait();
}

}  // namespace zoomwarp::tiles
