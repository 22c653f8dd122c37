// The line editor's suggestions: the straight edges the server detected at ingest (GET …/lines
// "suggested"), listed while the draw-line tool is on, each with accept (it joins the curator's
// lines) and drop (the server remembers it as dismissed), and accept all. The overlay draws them
// dashed and numbered as listed; the one under the pointer in the list is drawn thicker.

import { acceptSuggestions, dismissSuggestion } from './curator.js';

export class SuggestionPanel {
  // element: the panel's container (hidden while there is nothing to show); imageId: the image;
  // onEdited(image): after an edit, with the server's image JSON; onHighlight(index or null);
  // say(message): the status line.
  constructor({ element, imageId, onEdited, onHighlight, say }) {
    Object.assign(this, { element, imageId, onEdited, onHighlight, say });
    this.suggested = [];
    this.shown = false;
    this.busy = false;
  }

  update(suggested) {
    this.suggested = suggested;
    this.render();
  }

  show(shown) {
    this.shown = shown;
    this.element.hidden = !shown || this.suggested.length === 0;
    if (!shown) this.onHighlight(null);
  }

  render() {
    const heading = document.createElement('div');
    heading.textContent = `suggested lines (${this.suggested.length}) `;
    heading.append(this.button('accept all', 'accept-all', () =>
      this.act('accepting every suggested line…', () => acceptSuggestions(this.imageId, this.suggested))));
    const list = document.createElement('ol');
    this.suggested.forEach((line, index) => {
      const item = document.createElement('li');
      item.dataset.index = String(index);
      item.textContent = `${Math.round(Math.hypot(line[2] - line[0], line[3] - line[1]))} px `;
      item.append(
        this.button('accept', 'accept', () => this.act('accepting the line…', () => acceptSuggestions(this.imageId, [line]))),
        this.button('drop', 'drop', () => this.act('dropping the line…', () => dismissSuggestion(this.imageId, line))));
      item.addEventListener('pointerenter', () => this.onHighlight(index));
      item.addEventListener('pointerleave', () => this.onHighlight(null));
      list.append(item);
    });
    this.element.replaceChildren(heading, list);
    this.show(this.shown);
  }

  button(label, className, action) {
    const button = document.createElement('button');
    button.type = 'button';
    button.textContent = label;
    button.className = className;
    button.disabled = this.busy;
    button.addEventListener('click', action);
    return button;
  }

  // One edit at a time: each reads the lines afresh and publishes a new version.
  async act(message, edit) {
    if (this.busy) return;
    this.busy = true;
    for (const button of this.element.querySelectorAll('button')) button.disabled = true;
    this.say(message);
    try {
      this.onEdited(await edit());
    } catch (error) {
      this.say(error.message);
    } finally {
      this.busy = false;
      for (const button of this.element.querySelectorAll('button')) button.disabled = false;
    }
  }
}
