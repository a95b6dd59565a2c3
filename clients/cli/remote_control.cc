// dysa pause, resume, step, back (step back), reset.
#include <algorithm>
#include <ostream>

#include "remote_commands.h"
#include "remote_format.h"

namespace dysa::remote {

void RunControl(Client& client, ControlVerb verb, uint32_t count, bool json, std::ostream& out) {
  ControlResult r;
  switch (verb) {
    case ControlVerb::kPause:
      r = client.Pause();
      break;
    case ControlVerb::kResume:
      r = client.Resume();
      break;
    case ControlVerb::kStep:
      r = client.Step(count);
      break;
    case ControlVerb::kStepBack:
      r = client.StepBack(count);
      break;
    case ControlVerb::kReset:
      r = client.Reset();
      break;
  }
  if (json) return PrintJson(ToJson(r), out);
  const ServerStatus& s = r.status;
  switch (verb) {
    case ControlVerb::kPause:
      out << "paused at " << Where(s) << "\n";
      break;
    case ControlVerb::kResume:
      out << s.state << " from " << Where(s) << "\n";
      break;
    case ControlVerb::kStep:
      out << "stepped " << r.frames_moved << " frame" << (r.frames_moved == 1 ? "" : "s") << " to "
          << Where(s) << ", " << s.state << "\n";
      break;
    case ControlVerb::kStepBack:
      out << "stepped back " << r.frames_moved << " frame" << (r.frames_moved == 1 ? "" : "s")
          << " to " << Where(s) << ", " << s.state;
      if (r.frames_moved < std::max(count, 1u)) out << " (no older frame is kept)";
      out << "\n";
      break;
    case ControlVerb::kReset:
      out << "reset to " << Where(s) << ", " << s.particles << " particles, " << s.state << "\n";
      break;
  }
}

}  // namespace dysa::remote
