#pragma once
// One way the bake runs work on several threads (the tracing pool aside): oneTBB, in an arena of
// the bake's --threads.

#include <algorithm>
#include <cstddef>
#include <cstdint>

#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

namespace shrefract::bake {

// Runs body(i) for i in [0, count) on at most `threads` threads (oneTBB, in an arena of that
// size). Every body in the bake writes only its own index's slots and seeds its random numbers
// from the index, so the result does not depend on the schedule (bake_test,
// DeterministicAcrossThreadCounts and SearchesAreDeterministicAcrossThreadCounts).
template <class Body>
void parallelFor(size_t count, uint32_t threads, Body body) {
  tbb::task_arena arena(static_cast<int>(std::max(1u, threads)));
  arena.execute([&] { tbb::parallel_for(size_t(0), count, [&](size_t i) { body(i); }); });
}

}  // namespace shrefract::bake
