// The API docs page: Swagger UI from the installed package, reading this service's OpenAPI schema.
"use strict";
window.ui = SwaggerUIBundle({ url: "/openapi.json", dom_id: "#swagger-ui" });
