// Live progress: re-fetch the progress fragment every few seconds while the tab is visible.
const box = document.getElementById("progress");
const url = box.dataset.url;
const every = 1000 * Number(box.dataset.refresh || 5);

async function refresh() {
  if (document.hidden) return;
  try {
    const response = await fetch(url, { credentials: "same-origin", headers: { Accept: "text/html" } });
    if (response.ok) box.innerHTML = await response.text();
  } catch (err) {
    // offline for a moment: keep the last table
  }
}
setInterval(refresh, every);
document.body.dataset.ready = "1";
