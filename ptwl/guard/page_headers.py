"""What every answer of every server says about framing and scripts: one policy, used by
AccessGuard (the robot, the link and the replay) and the console's front door (viser's page).

No page may be framed (`frame-ancestors 'none'`, and X-Frame-Options for older browsers): a
framed console can be clicked by the page around it. Scripts, connections, images and workers
come only from the page's own origin, so text that got onto a page as markup could neither load
code from elsewhere nor send anything elsewhere.

What the pages need, and why each exception is there:
- viser's page boots from one inline script that unpacks its bundle (WebAssembly zstd) and
  injects it as an inline module: `'unsafe-inline'` and `'wasm-unsafe-eval'` for scripts, and
  inline styles. Inline scripts cannot be pinned by hash because the bundle's text is made in
  the browser, so the console's defence against injected markup is escaping (web/markup.py);
  this policy is the second wall.
- FastAPI's /docs loads Swagger UI from cdn.jsdelivr.net and starts it with an inline script.
"""

CONSOLE_CSP = (
    "default-src 'self'; script-src 'self' 'unsafe-inline' 'wasm-unsafe-eval'; "
    "style-src 'self' 'unsafe-inline'; img-src 'self' data: blob:; font-src 'self' data:; "
    "connect-src 'self'; worker-src 'self' blob:; object-src 'none'; base-uri 'none'; "
    "form-action 'none'; frame-ancestors 'none'"
)
DOCS_CDN = "https://cdn.jsdelivr.net"
API_CSP = (
    f"default-src 'self'; script-src 'self' 'unsafe-inline' {DOCS_CDN}; style-src 'self' 'unsafe-inline' "
    f"{DOCS_CDN}; img-src 'self' data: https://fastapi.tiangolo.com; connect-src 'self'; object-src 'none'; "
    "base-uri 'none'; form-action 'none'; frame-ancestors 'none'"
)


def page_headers(csp: str) -> dict[str, str]:
    """The headers every answer carries (lowercase names)."""
    return {
        "content-security-policy": csp,
        "x-frame-options": "DENY",
        "x-content-type-options": "nosniff",
        "referrer-policy": "no-referrer",
    }


def with_page_headers(headers: list[tuple[bytes, bytes]], csp: str) -> list[tuple[bytes, bytes]]:
    """`headers` (ASGI's raw pairs) with ours set: any the app sent of the same name replaced."""
    ours = page_headers(csp)
    kept = [(k, v) for k, v in headers if k.decode("latin-1").lower() not in ours]
    return kept + [(k.encode(), v.encode()) for k, v in ours.items()]
