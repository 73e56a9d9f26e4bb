// Calls spread over threads the process keeps, which the calling thread takes back when they
// are late.
#pragma once

#include <functional>

namespace rayclass {

// Runs f(t) for every t in [0, n), each once: f(0) on the calling thread, the others on helper
// threads kept for the process, except those no helper has begun once the calling thread is
// done with its own, which it then runs itself. On a busy machine a thread started for the call
// could wait milliseconds for a core while the calling thread waited for it, idle; a kept
// thread also costs no start. The calls must not wait for each other (no barrier between
// them): they may run one after the other. An exception from a call is rethrown here once
// every begun call is done.
void OnHelpers(int n, const std::function<void(int)>& f);

}  // namespace rayclass
