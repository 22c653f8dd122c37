// The warp methods the server offers (GET /v1/methods: each one's name, summary, what zoom means
// for it and whether it has a mesh) with the saliency kinds, the panes' choices among them, and
// the menus that make those choices: a method and a saliency per pane.

import { authorizedFetch } from './curator.js';

// {methods: [{name, summary, zoom, mesh}, …], saliency: ['default', …]}, in the server's order
// (its first method is the default). The list changes only with the server's build, so the
// browser's cache may answer (the server revalidates it by ETag).
export async function fetchMethods() {
  const response = await authorizedFetch('/v1/methods');
  if (!response.ok) throw new Error(`method list: HTTP ${response.status}`);
  return response.json();
}

// The entry of method `name`, or undefined.
export function describeMethod(catalogue, name) {
  return catalogue.methods.find((m) => m.name === name);
}

// `wanted` panes' choices ([{method?, saliency?}], e.g. from a shared link) as the server can
// show them: one or two panes; a method or saliency left out is the server's first, one it does
// not offer too, and that is said in `problems`.
export function validChoices(catalogue, wanted) {
  const problems = [];
  const choices = (wanted.length > 0 ? wanted : [{}]).slice(0, 2).map(({ method, saliency }) => {
    const known = describeMethod(catalogue, method) !== undefined;
    if (method !== undefined && !known) problems.push(`this server has no method '${method}'`);
    const knownSaliency = catalogue.saliency.includes(saliency);
    if (saliency !== undefined && !knownSaliency) problems.push(`this server has no saliency '${saliency}'`);
    return { method: known ? method : catalogue.methods[0].name, saliency: knownSaliency ? saliency : catalogue.saliency[0] };
  });
  return { choices, problems };
}

// What the second pane shows when side by side is turned on: the first method other than the
// first pane's, with the same saliency, so the two differ in the method alone.
export function secondChoice(catalogue, first) {
  const other = catalogue.methods.find((m) => m.name !== first.method) ?? catalogue.methods[0];
  return { method: other.name, saliency: first.saliency };
}

// One pane's two menus, a method <select> and a saliency <select>, filled from the catalogue.
// Each method option's tooltip (and the menu's, for the method chosen) says what it does and what
// zoom means for it.
export class MethodMenu {
  constructor(catalogue, methodSelect, saliencySelect) {
    Object.assign(this, { catalogue, methodSelect, saliencySelect });
    for (const m of catalogue.methods) {
      const option = new Option(m.name, m.name);
      option.title = tooltip(m);
      methodSelect.add(option);
    }
    for (const kind of catalogue.saliency) saliencySelect.add(new Option(`saliency: ${kind}`, kind));
    methodSelect.addEventListener('change', () => this.explain());
  }

  get value() {
    return { method: this.methodSelect.value, saliency: this.saliencySelect.value };
  }

  set value({ method, saliency }) {
    this.methodSelect.value = method;
    this.saliencySelect.value = saliency;
    this.explain();
  }

  // listener() after the user changed either menu.
  onChange(listener) {
    for (const select of [this.methodSelect, this.saliencySelect]) select.addEventListener('change', listener);
  }

  explain() {
    const method = describeMethod(this.catalogue, this.methodSelect.value);
    this.methodSelect.title = method ? tooltip(method) : '';
  }
}

function tooltip({ summary, zoom, mesh }) {
  return `${summary}\nzoom — ${zoom}${mesh ? '' : '\nNo mesh: shown as the server renders each view.'}`;
}
