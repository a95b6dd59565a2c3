// Child processes of a test die with it: a test killed (ctest's timeout, Ctrl-C on the runner,
// SIGKILL) leaves no server, viewer or X server running behind it.
#pragma once

#include <signal.h>
#include <sys/prctl.h>

namespace dysa::testing {

// Between fork and exec, in the child: the kernel sends it SIGKILL when the thread that forked
// it exits. Async-signal-safe (one system call); kept across exec.
inline void DieWithParent() { prctl(PR_SET_PDEATHSIG, SIGKILL); }

}  // namespace dysa::testing
