// JSON calls to the server with the CSRF header; failures become readable sentences.

export class ApiError extends Error {
  constructor(status, message, confirm = null) {
    super(message);
    this.status = status;
    this.confirm = confirm; // a 409 that goes ahead when repeated with this flag set
  }
}

export function createApi(sessionId, csrf, onReachable) {
  async function call(method, path, body) {
    let response;
    try {
      response = await fetch(path, {
        method,
        headers: { "Content-Type": "application/json", "X-CSRF-Token": csrf },
        body: body === undefined ? undefined : JSON.stringify(body),
        credentials: "same-origin",
      });
    } catch (error) {
      onReachable(false);
      throw new ApiError(0, "The server is unreachable. Check the network; nothing was saved.");
    }
    onReachable(true);
    if (response.status === 401) {
      throw new ApiError(401, "You are logged out. Reload the page and log in again.");
    }
    const data = await response.json().catch(() => ({}));
    if (!response.ok) {
      const detail = data.detail;
      if (detail && typeof detail === "object" && detail.message) {
        throw new ApiError(response.status, detail.message, detail.confirm || null);
      }
      const text = typeof detail === "string" ? detail : JSON.stringify(detail);
      throw new ApiError(response.status, text || `The server answered ${response.status}.`);
    }
    return data;
  }
  const wizard = `/api/wizard/sessions/${sessionId}`;
  const session = `/api/sessions/${sessionId}`;
  return {
    console: () => call("GET", `${wizard}/console`),
    prompts: (position) => call("GET", `${wizard}/prompts?position=${position}`),
    play: (group) => call("POST", `${wizard}/prompts/play`, { group }),
    stop: () => call("POST", `${wizard}/prompts/stop`, {}),
    robotApply: () => call("POST", `${wizard}/robot/apply`, {}),
    robotRetry: () => call("POST", `${wizard}/robot/retry`, {}),
    pairCapture: () => call("POST", `${wizard}/capture/reset-pairing`, {}),
    start: () => call("POST", `${session}/start`, {}),
    advance: (position, to) => call("POST", `${session}/advance`, { position, to }),
    decide: (position, index, accepted) =>
      call("POST", `${session}/decide`, { position, index, accepted }),
    undo: (position, index) => call("POST", `${session}/undo`, { position, index }),
    condition: (position, condition, confirmDeviation = false) =>
      call("POST", `${session}/condition`, { position, condition, confirm_deviation: confirmDeviation }),
    end: (reason, note) => call("POST", `${session}/end`, { reason, note }),
    pause: (reason, note) => call("POST", `${session}/pause`, { reason, note }),
    resume: () => call("POST", `${session}/resume`, {}),
    disconnectPhone: (device) =>
      call("POST", `${session}/phones/${encodeURIComponent(device)}/disconnect`, {}),
    note: (text) => call("POST", `${session}/notes`, { text }),
    say: (text) => call("POST", `${wizard}/prompts/say`, { text }),
  };
}
