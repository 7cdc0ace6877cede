// The console's WebSocket: reconnects by itself (with backoff) and pings to notice a dead link.

const PING_EVERY_MS = 5000;
const DEAD_AFTER_MS = 12000;
const SIGNED_OUT = 4401; // the server closed the socket: this login has ended

export function connectLive(sessionId, handlers) {
  let socket = null;
  let retry = 0;
  let lastHeard = 0;
  let pinger = null;
  let closedByUs = false;

  function open() {
    const scheme = location.protocol === "https:" ? "wss" : "ws";
    socket = new WebSocket(`${scheme}://${location.host}/ws/wizard/sessions/${sessionId}`);
    socket.addEventListener("open", () => {
      retry = 0;
      lastHeard = Date.now();
      handlers.onStatus(true);
      pinger = setInterval(ping, PING_EVERY_MS);
    });
    socket.addEventListener("message", (message) => {
      lastHeard = Date.now();
      let data;
      try {
        data = JSON.parse(message.data);
      } catch {
        return;
      }
      handlers.onMessage(data);
    });
    socket.addEventListener("close", (event) => {
      clearInterval(pinger);
      handlers.onStatus(false, event.code);
      if (closedByUs) return;
      if (event.code === SIGNED_OUT && handlers.onSignedOut) {
        // Logged out elsewhere or deactivated: retrying would only be refused.
        handlers.onSignedOut();
        return;
      }
      const delay = Math.min(8000, 500 * 2 ** retry);
      retry += 1;
      setTimeout(open, delay);
    });
  }

  function ping() {
    if (Date.now() - lastHeard > DEAD_AFTER_MS) {
      socket.close();
      return;
    }
    if (socket.readyState === WebSocket.OPEN) socket.send(JSON.stringify({ type: "ping" }));
  }

  open();
  return {
    close() {
      closedByUs = true;
      socket.close();
    },
  };
}
