// A scene's colours (plain ES module). The one palette of a domain is its Python `palette`
// (teaching/domains/<name>/page.py): the page writes it as CSS custom properties (--scene-<name>)
// and the legend's swatches, this canvas and the staff contact sheet all draw with it. A scene
// names the colours it needs (camelCase: goalHatch is --scene-goal-hatch); a missing one is an
// error, not a silent fallback, so a palette and its scene cannot drift apart unnoticed.

const cache = new Map();

export function colors(names) {
  const css = getComputedStyle(document.documentElement);
  const out = {};
  for (const name of names) {
    if (!cache.has(name)) {
      const prop = `--scene-${name.replace(/[A-Z]/g, (c) => "-" + c.toLowerCase())}`;
      const value = css.getPropertyValue(prop).trim();
      if (!value) throw new Error(`the page has no ${prop}: it needs its domain's palette (studyapp/scenes.py)`);
      cache.set(name, value);
    }
    out[name] = cache.get(name);
  }
  return out;
}
