"""The web server: the page, the API, the WebSockets and the feeds pages are sent."""
