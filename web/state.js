// What the viewer shows, kept in the URL's hash so that a view, and a comparison of two methods
// on it, can be shared as a link:
//
//   /?image=boats#method=icaz&saliency=default&method2=seam&saliency2=gbvs&zoom=0.4&cx=1200&cy=700
//
// method/saliency choose the first pane, method2/saliency2 the second one of the side-by-side
// mode (absent: one pane); zoom, cx, cy are the view both panes show. The image stays the query's
// ?image=. Pure functions of strings, no DOM; the names are checked against the server's methods
// by the caller (methods.js validChoices).

const PANE_KEYS = [['method', 'saliency'], ['method2', 'saliency2']];
const VIEW_KEYS = ['zoom', 'cx', 'cy'];

// {view: {zoom?, cx?, cy?}, panes: [{method, saliency?}, …]} of a location.hash; what is missing
// or not a number is left out.
export function parseState(hash) {
  const params = new URLSearchParams(hash.replace(/^#/, ''));
  const view = {};
  for (const key of VIEW_KEYS) {
    const value = params.get(key);
    if (value !== null && value.trim() !== '' && Number.isFinite(Number(value))) view[key] = Number(value);
  }
  const panes = [];
  for (const [method, saliency] of PANE_KEYS) {
    if (!params.has(method)) break;
    panes.push({ method: params.get(method), saliency: params.get(saliency) ?? undefined });
  }
  return { view, panes };
}

// The hash of a state: panes [{method, saliency}] (one or two), view {zoom, cx, cy}.
export function formatState({ panes, view }) {
  const params = new URLSearchParams();
  panes.slice(0, PANE_KEYS.length).forEach(({ method, saliency }, k) => {
    params.set(PANE_KEYS[k][0], method);
    params.set(PANE_KEYS[k][1], saliency);
  });
  for (const key of VIEW_KEYS) params.set(key, String(view[key]));
  return `#${params}`;
}

// The hash without its view: the methods carry over to another image, the view would not fit it.
export function withoutView(hash) {
  const params = new URLSearchParams(hash.replace(/^#/, ''));
  for (const key of VIEW_KEYS) params.delete(key);
  const rest = params.toString();
  return rest ? `#${rest}` : '';
}
