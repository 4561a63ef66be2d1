#include "motion/serial/sim_link.hpp"

#include "motion/serial/pty_link.hpp"
#include "motion/serial/socket_link.hpp"

namespace motion::serial {

std::string_view to_string(SimLinkKind kind) { return kind == SimLinkKind::kSocket ? "socket" : "pty"; }

std::unique_ptr<SimLink> create_sim_link(SimLinkKind kind, const std::string& link_path, const SerialSettings& settings,
                                         std::error_code& error, const FileAccess& access) {
  if (kind == SimLinkKind::kSocket) return SocketLink::create(link_path, error, access);
  return PtyLink::create(link_path, settings, error, access);
}

}  // namespace motion::serial
