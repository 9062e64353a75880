// Translating what the participant pages' scripts show (plain ES module, no build step).
//
// A participant page loads the study's JavaScript catalog (Django's JavaScriptCatalog, domain
// "djangojs", in the study's language: studyapp/i18n.py) as a classic script before its modules,
// which defines globalThis.gettext, ngettext and interpolate. The researchers' pages (the stimuli
// sheet) run the same scene scripts without that catalog, and a page whose catalog failed to load
// must still work: there these fall back to the English the scripts are written in, so a missing
// catalog never breaks a page, it only leaves it in English.
//
// Every text a participant reads is written as a literal gettext("...") (or ngettext) call in the
// source, so that `makemessages -d djangojs` finds it; values go in through interpolate with named
// placeholders, so a translation can put them where its word order needs them.

const catalog = globalThis;

export function gettext(text) {
  return typeof catalog.gettext === "function" ? catalog.gettext(text) : text;
}

export function ngettext(singular, plural, n) {
  return typeof catalog.ngettext === "function" ? catalog.ngettext(singular, plural, n) : (n === 1 ? singular : plural);
}

// Django's interpolate: `named` true fills %(name)s from obj's keys, else each %s from the array obj in turn.
export function interpolate(fmt, obj, named = false) {
  if (typeof catalog.interpolate === "function") return catalog.interpolate(fmt, obj, named);
  if (named) return fmt.replace(/%\(\w+\)s/g, (match) => String(obj[match.slice(2, -2)]));
  let k = 0;
  return fmt.replace(/%s/g, () => String(obj[k++]));
}
