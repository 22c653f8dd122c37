// Reads the server asks to repeat later. A first view of an image waits for its analysis at most
// --request-timeout (5 s by default); past that the server answers 503 "analysis_pending" with
// Retry-After while the analysis goes on in the background, and the retry finds it done
// (api/warp_engines.h). A busy server (503 "busy") and a rate limit (429) answer the same way.
// A thin client is expected to honour Retry-After; this is the viewer's doing so.
//
// Only reads are repeated: an edit answered 503 was not made, and the curator decides whether
// to make it again.

// All the waiting one read may do before its 503 is shown as the error it is.
const MAX_TOTAL_WAIT_MS = 120_000;
// One wait at least (a Retry-After of 0) and at most (a server asking for minutes).
const MIN_WAIT_MS = 250;
const MAX_WAIT_MS = 15_000;

const listeners = [];

// listener({url, status, code, seconds}) before each wait: code is the server's error code
// ('analysis_pending', 'busy', …) or '' when the body has none.
export function onRetryWait(listener) {
  listeners.push(listener);
}

// send() → Promise<Response>, called again after each wait the answer asks for.
export async function retryingRead(url, send) {
  let waited = 0;
  for (;;) {
    const response = await send();
    const ms = retryAfterMs(response);
    if (ms === null || waited + ms > MAX_TOTAL_WAIT_MS) return response;
    const code = await errorCode(response);
    for (const listener of listeners) listener({ url, status: response.status, code, seconds: ms / 1000 });
    await new Promise((resolve) => setTimeout(resolve, ms));
    waited += ms;
  }
}

// Milliseconds to wait before asking again, or null when the answer is final. Retry-After is
// delay-seconds or an HTTP date (RFC 9110 §10.2.3); a header that is neither is not a request
// to retry.
function retryAfterMs(response) {
  if (response.status !== 503 && response.status !== 429) return null;
  const value = response.headers.get('Retry-After')?.trim();
  if (!value) return null;
  const ms = /^\d+$/.test(value) ? Number(value) * 1000 : Date.parse(value) - Date.now();
  if (Number.isNaN(ms)) return null;
  return Math.min(MAX_WAIT_MS, Math.max(MIN_WAIT_MS, ms));
}

// The JSON error's code, read from a copy so that the answer stays readable.
async function errorCode(response) {
  try {
    return (await response.clone().json()).error?.code ?? '';
  } catch {
    return '';
  }
}
