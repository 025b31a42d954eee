// The REST API's documentation, drawn by Swagger UI from the server's own OpenAPI document.
window.ui = SwaggerUIBundle({ url: '/openapi.json', dom_id: '#swagger-ui', deepLinking: true });
