// Keepalive settings chosen together for weavefitd and its clients. A long
// fit sends no data for seconds to minutes; the client keeps the connection
// alive with pings, and the server must accept them rather than close the
// connection with "too many pings" (GOAWAY ENHANCE_YOUR_CALM).
#ifndef WEAVEFIT_PROTO_WEAVEFIT_V1_KEEPALIVE_H_
#define WEAVEFIT_PROTO_WEAVEFIT_V1_KEEPALIVE_H_

namespace weavefit {

// Client: a ping every 30 s on an open call, answered within 10 s, with no
// cap on pings while no data flows (gRPC's default cap of 2 would stop them).
constexpr int kClientKeepaliveTimeMs = 30000;
constexpr int kClientKeepaliveTimeoutMs = 10000;

// Server: accepts a client ping every 10 s or slower (a third of the
// client's period, so a late timer never counts as a strike), and pings idle
// connections itself every 60 s to find clients that vanished (their
// admission is given back when the connection drops).
constexpr int kServerMinPingIntervalMs = 10000;
constexpr int kServerKeepaliveTimeMs = 60000;
constexpr int kServerKeepaliveTimeoutMs = 20000;

static_assert(kServerMinPingIntervalMs < kClientKeepaliveTimeMs,
              "the server must accept the client's pings");

}  // namespace weavefit

#endif  // WEAVEFIT_PROTO_WEAVEFIT_V1_KEEPALIVE_H_
