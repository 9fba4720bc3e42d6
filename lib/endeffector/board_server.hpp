// Serves a BoardEmulator on a TCP port, the way ser2net serves a real board:
// non-blocking, one client at a time; a new connection replaces the old one
// (a host that reconnects after a silent spell must not be locked out by its
// own half-open socket). Drive it by calling service() often (a timer or a
// loop); it never blocks.
#pragma once

#include <string>

#include "endeffector/board_emulator.hpp"

namespace harvest::endeffector {

class BoardServer {
 public:
  // port 0: pick a free port (see port()).
  BoardServer(BoardEmulator& board, const std::string& host, int port);
  ~BoardServer();
  BoardServer(const BoardServer&) = delete;
  BoardServer& operator=(const BoardServer&) = delete;

  int port() const { return port_; }
  int listen_fd() const { return listen_fd_; }
  int client_fd() const { return client_fd_; }
  bool has_client() const { return client_fd_ >= 0; }
  int64_t connections() const { return connections_; }
  int64_t dropped_bytes() const { return dropped_; }

  // Accept, read, run the board, write. Non-blocking.
  void service(Micros now);

  // Fault injection: send the first half of one more frame, then close the connection.
  void close_mid_frame(Micros now);
  void close_client();

 private:
  void flush();

  BoardEmulator& board_;
  int listen_fd_ = -1;
  int client_fd_ = -1;
  int port_ = 0;
  std::string pending_;  // bytes the socket did not take yet
  int64_t connections_ = 0;
  int64_t dropped_ = 0;
};

}  // namespace harvest::endeffector
