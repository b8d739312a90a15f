// The run's token (view/README.md, "Access"): modal-rt prints the page's address with ?token=HEX;
// the page passes it on to /api/* (the X-Modal-RT-Token header) and to /ws (the query). A reload of
// the address without it still works through the cookie the server set on the first load.
const token = new URLSearchParams(location.search).get('token');

// GET `path` of the API; a refusal (401, 403) is shown in the status line and thrown.
export async function api(path) {
  const response = await fetch(path, token ? { headers: { 'X-Modal-RT-Token': token } } : {});
  if (response.status === 401 || response.status === 403) {
    const reason = (await response.text()).trim();
    document.getElementById('status').textContent = reason;
    throw new Error(`${path}: ${response.status} ${reason}`);
  }
  return response;
}

// The live socket's address, with the token.
export function socketUrl() {
  const protocol = location.protocol === 'https:' ? 'wss' : 'ws';
  return `${protocol}://${location.host}/ws${token ? `?token=${encodeURIComponent(token)}` : ''}`;
}
