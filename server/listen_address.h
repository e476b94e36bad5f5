// Listening addresses of the design service's doors: whether one is free before the service opens its
// data folder, and who holds it when it is not.
//
//   CheckAddressFree   binds HOST:PORT as the doors bind (SO_REUSEADDR, which only lets a port in
//                      TIME_WAIT be taken again; never SO_REUSEPORT, with which a second server would
//                      share the port and the kernel deal connections between the two) and lets it go
//   AddressInUse       the refusal: "--http 127.0.0.1:7448: address already in use (by pid 4242: kgd
//                      serve --data ...)"
//   PortHolder         the process listening on a TCP port, from /proc/net/tcp{,6} (the socket's
//                      inode) and /proc/PID/fd (which process has it open); best effort: empty when
//                      /proc does not say (another user's process, another network namespace)
#pragma once

#include <string>

#include "core/util/status.h"

namespace kgd::server {

// `flag` names the address in the message ("--listen"). Port 0 (any free port) is always free; an
// address that cannot be bound for another reason (not this machine's) is left to the door to refuse.
Status CheckAddressFree(const std::string& flag, const std::string& address);

Status AddressInUse(const std::string& flag, const std::string& address);

// "pid N: COMMAND LINE" of the process listening on TCP `port`; empty when not found.
std::string PortHolder(int port);

}  // namespace kgd::server
